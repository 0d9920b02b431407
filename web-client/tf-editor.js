// Transfer-function editor: a piecewise-linear opacity curve over the attribute histogram.
// Drag a point to move it; double-click to add one; right-click a point to remove it (the
// two end points stay). onChange(points) gets [[value, alpha], ...] in attribute units.
export class TfEditor {
  constructor(canvas, onChange) {
    this.canvas = canvas;
    this.onChange = onChange;
    this.range = [0, 1];
    this.histogram = [];
    this.points = [[0, 0], [1, 1]];  // normalised value, alpha
    this.colors = null;
    this.dragging = -1;
    canvas.addEventListener('pointerdown', (e) => this.down(e));
    canvas.addEventListener('pointermove', (e) => this.move(e));
    canvas.addEventListener('pointerup', () => this.up());
    canvas.addEventListener('pointercancel', () => this.up());
    canvas.addEventListener('dblclick', (e) => this.addPoint(e));
    canvas.addEventListener('contextmenu', (e) => this.removePoint(e));
  }

  setData(range, histogram, colors) {
    this.range = range;
    this.histogram = histogram ?? [];
    if (colors) this.colors = colors;
    this.draw();
  }

  setColors(colors) {
    this.colors = colors;
    this.draw();
  }

  reset() {
    this.points = [[0, 0], [1, 1]];
    this.draw();
    this.emit();
  }

  valuePoints() {
    const [lo, hi] = this.range;
    return this.points.map(([t, a]) => [lo + t * (hi - lo), a]);
  }

  emit() {
    this.onChange(this.valuePoints());
  }

  at(e) {
    const r = this.canvas.getBoundingClientRect();
    const t = Math.min(Math.max((e.clientX - r.left) / r.width, 0), 1);
    const a = Math.min(Math.max(1 - (e.clientY - r.top) / r.height, 0), 1);
    return [t, a];
  }

  nearest(e) {
    const r = this.canvas.getBoundingClientRect();
    let best = -1, bestDistance = 12;
    this.points.forEach(([t, a], i) => {
      const d = Math.hypot(t * r.width - (e.clientX - r.left), (1 - a) * r.height - (e.clientY - r.top));
      if (d < bestDistance) {
        best = i;
        bestDistance = d;
      }
    });
    return best;
  }

  down(e) {
    if (e.button !== 0) return;
    this.dragging = this.nearest(e);
    if (this.dragging < 0) {  // a click on the curve's side adds a point and drags it
      this.addPoint(e);
      this.dragging = this.nearest(e);
    }
    if (this.dragging >= 0) this.canvas.setPointerCapture(e.pointerId);
  }

  move(e) {
    if (this.dragging < 0) return;
    let [t, a] = this.at(e);
    const i = this.dragging, n = this.points.length;
    if (i === 0) t = 0;
    else if (i === n - 1) t = 1;
    else t = Math.min(Math.max(t, this.points[i - 1][0]), this.points[i + 1][0]);
    this.points[i] = [t, a];
    this.draw();
    this.emit();
  }

  up() {
    this.dragging = -1;
  }

  addPoint(e) {
    const [t, a] = this.at(e);
    if (this.points.length >= 64) return;
    let i = this.points.findIndex(([pt]) => pt > t);
    if (i <= 0) i = this.points.length - 1;
    this.points.splice(i, 0, [t, a]);
    this.draw();
    this.emit();
  }

  removePoint(e) {
    e.preventDefault();
    const i = this.nearest(e);
    if (i <= 0 || i >= this.points.length - 1) return;
    this.points.splice(i, 1);
    this.draw();
    this.emit();
  }

  draw() {
    const c = this.canvas, g = c.getContext('2d');
    const w = c.width, h = c.height;
    g.clearRect(0, 0, w, h);
    // colour strip
    if (this.colors) {
      const n = this.colors.length;
      for (let x = 0; x < w; ++x) {
        const rgb = this.colors[Math.min(n - 1, Math.floor((x / w) * n))];
        g.fillStyle = `rgb(${rgb.map((v) => Math.round(v * 255)).join(',')})`;
        g.fillRect(x, h - 6, 1, 6);
      }
    }
    // histogram, log scale
    const bins = this.histogram;
    if (bins.length) {
      const top = Math.log1p(Math.max(...bins));
      g.fillStyle = '#3a4258';
      bins.forEach((count, b) => {
        const bh = top > 0 ? (Math.log1p(count) / top) * (h - 8) : 0;
        g.fillRect((b / bins.length) * w, h - 6 - bh, w / bins.length - 1, bh);
      });
    }
    // opacity curve
    g.strokeStyle = '#e8e8f0';
    g.lineWidth = 1.5;
    g.beginPath();
    this.points.forEach(([t, a], i) => (i ? g.lineTo(t * w, (1 - a) * (h - 6)) : g.moveTo(t * w, (1 - a) * (h - 6))));
    g.stroke();
    g.fillStyle = '#ffd34d';
    for (const [t, a] of this.points) {
      g.beginPath();
      g.arc(t * w, (1 - a) * (h - 6), 4, 0, 2 * Math.PI);
      g.fill();
    }
  }
}
