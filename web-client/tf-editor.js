// Transfer-function editor: a piecewise-linear opacity curve over the attribute histogram,
// and the colour points on a strip below it. Both live in normalised units t in [0, 1] over
// the range; the caller maps them onto attribute values.
//  - opacity: drag a point; click or double-click beside the curve to add one; right-click a
//    point to remove it (the two end points stay, and move only up and down);
//  - colours: click the strip to add a point (the colour there), drag a marker to move it,
//    click a marker to select it (then recolour it with the colour input the caller wires to
//    recolorSelected), double-click to recolour at once, right-click to remove (ends stay).
// onChange() is called after every edit; read opacityPoints and colorPoints.
import { colorAt, toCss, toHex } from './colormaps.js';
import { rebin } from './view-state.js';

const kStripHeight = 18;   // colour strip and its markers, canvas pixels
const kBandHeight = 8;     // the colour band at the strip's top; markers below it
const kPick = 10;          // pick radius, CSS pixels
const kMaxPoints = 64;

export class TfEditor {
  constructor(canvas, onChange, { onSelectColor = () => {} } = {}) {
    this.canvas = canvas;
    this.onChange = onChange;
    this.onSelectColor = onSelectColor;
    this.histogram = [];       // counts over histogramRange
    this.histogramRange = [0, 1];
    this.range = [0, 1];       // what t spans
    this.opacityPoints = [[0, 0], [1, 1]];
    this.colorPoints = [[0, 0, 0, 0], [1, 1, 1, 1]];
    this.selected = -1;        // selected colour point
    this.drag = null;          // {kind: 'opacity' | 'color', index}
    canvas.addEventListener('pointerdown', (e) => this.down(e));
    canvas.addEventListener('pointermove', (e) => this.move(e));
    canvas.addEventListener('pointerup', () => (this.drag = null));
    canvas.addEventListener('pointercancel', () => (this.drag = null));
    canvas.addEventListener('dblclick', (e) => this.doubleClick(e));
    canvas.addEventListener('contextmenu', (e) => this.remove(e));
  }

  setHistogram(histogramRange, histogram) {
    this.histogramRange = histogramRange;
    this.histogram = histogram ?? [];
    this.draw();
  }

  set(range, opacityPoints, colorPoints) {
    this.range = range;
    this.opacityPoints = opacityPoints.map((p) => [...p]);
    this.colorPoints = colorPoints.map((p) => [...p]);
    if (this.selected >= this.colorPoints.length) this.selected = -1;
    this.draw();
  }

  recolorSelected(rgb) {
    if (this.selected < 0) return;
    this.colorPoints[this.selected] = [this.colorPoints[this.selected][0], ...rgb];
    this.changed();
  }

  selectedColor() {
    return this.selected >= 0 ? this.colorPoints[this.selected].slice(1) : null;
  }

  changed() {
    this.draw();
    this.onChange();
  }

  // pointer position: t, alpha (over the curve area) and whether it is on the strip
  at(e) {
    const r = this.canvas.getBoundingClientRect();
    const curveHeight = r.height * (1 - kStripHeight / this.canvas.height);
    const t = Math.min(Math.max((e.clientX - r.left) / r.width, 0), 1);
    const y = e.clientY - r.top;
    return { t, alpha: Math.min(Math.max(1 - y / curveHeight, 0), 1), onStrip: y > curveHeight, x: e.clientX - r.left, y, r, curveHeight };
  }

  nearestOpacity(p) {
    let best = -1, bestDistance = kPick;
    this.opacityPoints.forEach(([t, a], i) => {
      const d = Math.hypot(t * p.r.width - p.x, (1 - a) * p.curveHeight - p.y);
      if (d < bestDistance) [best, bestDistance] = [i, d];
    });
    return best;
  }

  nearestColor(p) {
    let best = -1, bestDistance = kPick;
    this.colorPoints.forEach(([t], i) => {
      const d = Math.abs(t * p.r.width - p.x);
      if (d < bestDistance) [best, bestDistance] = [i, d];
    });
    return best;
  }

  down(e) {
    if (e.button !== 0) return;
    const p = this.at(e);
    if (p.onStrip) {
      let i = this.nearestColor(p);
      if (i < 0) i = this.addColor(p.t);
      if (i < 0) return;
      this.selected = i;
      this.onSelectColor(this.selectedColor());
      this.drag = { kind: 'color', index: i };
      this.draw();
    } else {
      let i = this.nearestOpacity(p);
      if (i < 0) i = this.addOpacity(p.t, p.alpha);
      if (i < 0) return;
      this.drag = { kind: 'opacity', index: i };
    }
    this.canvas.setPointerCapture(e.pointerId);
  }

  move(e) {
    if (!this.drag) return;
    const p = this.at(e);
    const { kind, index: i } = this.drag;
    const points = kind === 'color' ? this.colorPoints : this.opacityPoints;
    const n = points.length;
    let t = p.t;
    if (i === 0) t = 0;
    else if (i === n - 1) t = 1;
    else t = Math.min(Math.max(t, points[i - 1][0]), points[i + 1][0]);
    if (kind === 'color') points[i] = [t, ...points[i].slice(1)];
    else points[i] = [t, p.alpha];
    this.changed();
  }

  addOpacity(t, alpha) {
    if (this.opacityPoints.length >= kMaxPoints) return -1;
    let i = this.opacityPoints.findIndex(([pt]) => pt > t);
    if (i <= 0) i = this.opacityPoints.length - 1;
    this.opacityPoints.splice(i, 0, [t, alpha]);
    this.changed();
    return i;
  }

  addColor(t) {
    if (this.colorPoints.length >= kMaxPoints) return -1;
    let i = this.colorPoints.findIndex(([pt]) => pt > t);
    if (i <= 0) i = this.colorPoints.length - 1;
    this.colorPoints.splice(i, 0, [t, ...colorAt(this.colorPoints, t)]);
    this.changed();
    return i;
  }

  doubleClick(e) {
    const p = this.at(e);
    if (!p.onStrip) return;
    const i = this.nearestColor(p);
    if (i < 0) return;
    this.selected = i;
    this.onSelectColor(this.selectedColor(), true);  // true: open the picker
    this.draw();
  }

  remove(e) {
    e.preventDefault();
    const p = this.at(e);
    const points = p.onStrip ? this.colorPoints : this.opacityPoints;
    const i = p.onStrip ? this.nearestColor(p) : this.nearestOpacity(p);
    if (i <= 0 || i >= points.length - 1) return;
    points.splice(i, 1);
    if (p.onStrip) this.selected = -1;
    this.changed();
  }

  draw() {
    const c = this.canvas, g = c.getContext('2d');
    const w = c.width, h = c.height, ch = h - kStripHeight;
    g.clearRect(0, 0, w, h);
    // colour strip
    for (let x = 0; x < w; ++x) {
      g.fillStyle = toCss(colorAt(this.colorPoints, x / (w - 1)));
      g.fillRect(x, ch + 2, 1, kBandHeight);
    }
    // histogram, log scale, re-binned from the server's bins onto the range (each source bin
    // spread evenly over its own span)
    const bins = this.histogram;
    if (bins.length) {
      const out = 64, shown = rebin(bins, this.histogramRange, this.range, out);
      const top = Math.log1p(Math.max(...shown));
      g.fillStyle = '#3a4258';
      shown.forEach((count, k) => {
        const bh = top > 0 ? (Math.log1p(count) / top) * (ch - 2) : 0;
        g.fillRect((k / out) * w, ch - bh, w / out - 1, bh);
      });
    }
    // opacity curve
    g.strokeStyle = '#e8e8f0';
    g.lineWidth = 1.5;
    g.beginPath();
    this.opacityPoints.forEach(([t, a], i) => (i ? g.lineTo(t * w, (1 - a) * ch) : g.moveTo(t * w, (1 - a) * ch)));
    g.stroke();
    g.fillStyle = '#ffd34d';
    for (const [t, a] of this.opacityPoints) {
      g.beginPath();
      g.arc(t * w, (1 - a) * ch, 4, 0, 2 * Math.PI);
      g.fill();
    }
    // colour point markers: small triangles under the band, pointing at it
    this.colorPoints.forEach(([t, ...rgb], i) => {
      const x = Math.min(Math.max(t * w, 4), w - 4), big = i === this.selected ? 1.5 : 0;
      g.beginPath();
      g.moveTo(x, ch + kBandHeight + 3);
      g.lineTo(x - 4 - big, h - 1);
      g.lineTo(x + 4 + big, h - 1);
      g.closePath();
      g.fillStyle = toHex(rgb);
      g.fill();
      g.lineWidth = i === this.selected ? 2 : 0.75;
      g.strokeStyle = i === this.selected ? '#ffd34d' : '#e8e8f0';
      g.stroke();
    });
  }
}
