// Stream lines (§7.3) and point isosurfaces (§7.2) in the viewer: a panel of its own (built
// here, appended to the side panel) that sends lines.set and points.set, and adds "lines" and
// "points" to the mode the app sends. What the panel shows lives in the view (view.lines,
// view-state.js), so it travels in the URL and is sent again after a reconnect.
//   const panel = new LinesPanel(container, canvas, { send, onModes, view, saved, camera });
//   panel.setDataset(info)   the dataset's vector fields fill the field list; the controls show view.lines
//   panel.modes()            ['lines'] / ['points'] / both, for mode.set
//   panel.sendAll()          lines.set (with its selection) and points.set for the view
//   panel.onFrame(header)    each frame shown (the dash animation waits for its frames)
// In the image, while "pick" is on a click selects the line under it (opaque, the others
// ghosted); while "draw rake" is on a drag draws a rake on the plane through the view's
// target facing the camera (the seeds), a shift-drag a selection box there (as deep as it is
// wide). With dashes, the panel moves them along the flow (dash_phase) while "animate" is on:
// one step when the frame of the last has arrived, at most kAnimationHz a second.

const kAnimationHz = 8;
const kPhaseStep = 0.125;      // of the dash spacing per step
const kStepTimeoutMs = 3000;   // a step whose frame never came (dropped): the next one anyway
const kDefaultGhost = 0.15;

export function defaultLines() {
  return {
    on: false, points: false,
    field: null,                 // null: the dataset's first vector field
    seeds: 'dense', count: 12,   // 'dense' (cells along the longest side) or 'rake' (seeds on from-to)
    from: null, to: null,        // rake ends [x, y, z]; null: across the middle of the box
    select: null,                // null: every line opaque; {lines}, {box} or {pixel} as in lines.set
    ghost: kDefaultGhost, flow: 'arrows', depth: 1,  // ghost opacity, flow marks, §7.3.3 depth correction
    animate: true,               // dashes move
    pointValues: [],             // point isovalues; none: 8 regular
  };
}

// ---------- the URL ----------

const num = (x) => String(+(+x).toPrecision(6));

// Keys: lfield, lseeds (dense:N or rake:x0,y0,z0,x1,y1,z1,N), lselect (ids:1,2 / box:x0,..,z1 /
// pick:x,y), lghost, lflow, ldepth, lpause, pvalues; "lines" and "points" go in mode=.
export function linesToHash(view) {
  const l = view.lines ?? defaultLines(), p = [];
  const put = (k, v) => p.push(`${k}=${encodeURIComponent(v).replace(/%2C/g, ',').replace(/%3A/g, ':')}`);
  if (l.field) put('lfield', l.field);
  if (l.seeds === 'rake' && l.from && l.to) put('lseeds', `rake:${[...l.from, ...l.to, l.count].map(num).join(',')}`);
  else if (l.count !== 12) put('lseeds', `dense:${l.count}`);
  if (l.select?.lines) put('lselect', `ids:${l.select.lines.join(',')}`);
  else if (l.select?.box) put('lselect', `box:${[...l.select.box[0], ...l.select.box[1]].map(num).join(',')}`);
  else if (l.select?.pixel) put('lselect', `pick:${l.select.pixel.map(num).join(',')}`);
  if (l.ghost !== kDefaultGhost) put('lghost', num(l.ghost));
  if (l.flow !== 'arrows') put('lflow', l.flow);
  if (l.depth !== 1) put('ldepth', num(l.depth));
  if (!l.animate) put('lpause', 1);
  if (l.pointValues.length) put('pvalues', l.pointValues.map(num).join(','));
  return p;
}

// Untrusted (a pasted link): a malformed field is dropped, the default stays. `h`: the
// fragment's decoded values by key; `modes`: the parts of mode=.
export function linesFromHash(h, modes = []) {
  const l = defaultLines();
  l.on = modes.includes('lines');
  l.points = modes.includes('points');
  const finite = (s) => s !== '' && Number.isFinite(Number(s));
  const nums = (text) => (text && text.split(',').every(finite) ? text.split(',').map(Number) : null);
  const field = h.get('lfield') ?? '';
  if (/^[^\s]{1,128}$/.test(field)) l.field = field;
  const [kind, rest] = (h.get('lseeds') ?? '').split(':');
  const s = nums(rest);
  const whole = (x, max) => Number.isInteger(x) && x >= 1 && x <= max;
  if (kind === 'dense' && s?.length === 1 && whole(s[0], 64)) l.count = s[0];
  if (kind === 'rake' && s?.length === 7 && whole(s[6], 2000) && s.every((x) => Math.abs(x) <= 1e30)) Object.assign(l, { seeds: 'rake', from: s.slice(0, 3), to: s.slice(3, 6), count: s[6] });
  const [sk, sr] = (h.get('lselect') ?? '').split(':');
  const sel = nums(sr);
  if (sk === 'ids' && sel && sel.length <= 4096 && sel.every((x) => Number.isInteger(x) && x >= 0 && x <= 0xffffffff)) l.select = { lines: [...new Set(sel)].sort((a, b) => a - b) };
  if (sk === 'box' && sel?.length === 6 && sel.every((x) => Math.abs(x) <= 1e30)) {
    l.select = { box: [[0, 1, 2].map((k) => Math.min(sel[k], sel[k + 3])), [0, 1, 2].map((k) => Math.max(sel[k], sel[k + 3]))] };
  }
  if (sk === 'pick' && sel?.length === 2 && sel.every((x) => x >= 0 && x <= 1)) l.select = { pixel: sel };
  if (finite(h.get('lghost') ?? '')) l.ghost = Math.min(Math.max(Number(h.get('lghost')), 0.02), 1);
  if (['arrows', 'dashes', 'none'].includes(h.get('lflow'))) l.flow = h.get('lflow');
  if (finite(h.get('ldepth') ?? '')) l.depth = Math.min(Math.max(Number(h.get('ldepth')), 0), 1);
  l.animate = h.get('lpause') !== '1';
  l.pointValues = (nums(h.get('pvalues')) ?? []).slice(0, 16);
  return l;
}

// A point of the image (fractions from the top left) on the plane through the camera's target
// facing it: the plane a drawn rake or box lies on.
export function pointOnViewPlane(camera, aspect, x, y) {
  const sub = (a, b) => a.map((v, i) => v - b[i]);
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const norm = (a) => a.map((v) => v / Math.hypot(...a));
  const offset = sub(camera.target, camera.eye);
  const forward = norm(offset);
  const right = norm(cross(forward, camera.up));
  const up = cross(right, forward);
  const height = camera.orthographic ? camera.height : 2 * Math.hypot(...offset) * Math.tan((camera.fov * Math.PI) / 360);
  const u = (2 * x - 1) * (height / 2) * aspect, v = (1 - 2 * y) * (height / 2);
  return camera.target.map((t, k) => t + u * right[k] + v * up[k]);
}

// ---------- the panel ----------

const html = `
<div class="lines-panel">
  <div class="row">
    <label><input type="checkbox" id="lines-on"> stream lines</label>
    <label><input type="checkbox" id="points-on"> point isosurfaces</label>
  </div>
  <label>Field <select id="lines-field"></select></label>
  <div class="row">
    <label>Seeds <select id="lines-seeds"><option value="dense">dense</option><option value="rake">rake</option></select></label>
    <label>Count <input type="number" id="lines-count" min="1" max="2000" value="12" style="width:5em"></label>
  </div>
  <div class="row" id="lines-rake" hidden>
    <label>From <input id="lines-from" placeholder="x,y,z" style="width:9em"></label>
    <label>To <input id="lines-to" placeholder="x,y,z" style="width:9em"></label>
  </div>
  <div class="row">
    <label title="drag in the image: a rake on the plane through the view's centre; shift-drag: a selection box"><input type="checkbox" id="lines-draw"> draw rake / box</label>
  </div>
  <div class="row">
    <label>Ghosts <input type="range" id="lines-ghost" min="2" max="100" value="15"></label>
    <label>Flow <select id="lines-flow"><option>arrows</option><option>dashes</option><option>none</option></select></label>
    <label id="lines-animate-label" hidden><input type="checkbox" id="lines-animate" checked> animate</label>
  </div>
  <div class="row">
    <label title="§7.3.3: 100% keeps halos and arrows their size in the image at every depth; 0% gives them a size in the world, so far ones are thinner and shorter">Depth correction <input type="range" id="lines-depth" min="0" max="100" value="100"></label>
  </div>
  <div class="row">
    <label><input type="checkbox" id="lines-pick"> pick lines (click)</label>
    <button type="button" id="lines-clear">show all</button>
  </div>
  <div class="row">
    <label>Select box <input id="lines-box" placeholder="x0,y0,z0,x1,y1,z1" style="width:12em"></label>
  </div>
  <label>Point isovalues <input id="points-values" placeholder="8 regular" style="width:12em"></label>
  <div class="lines-status" id="lines-status"></div>
</div>`;

const numbers = (text) =>
  text
    .split(',')
    .map((s) => s.trim())
    .filter((s) => s.length)
    .map(Number);
const fmt = (p) => p.map((x) => +x.toPrecision(4)).join(',');

export class LinesPanel {
  // host: { send(type, body) -> id, onModes(), view() -> the view, saved(), camera() -> camera.get() | null }
  constructor(container, canvas, host) {
    container.insertAdjacentHTML('beforeend', html);
    this.host = host;
    this.send = host.send;
    this.canvas = canvas;
    this.$ = (id) => container.querySelector(`#${id}`);
    this.phase = 0;
    this.step = null;  // the animation step waiting for its frame: {id, at}
    const $ = this.$;
    const l = () => this.l();
    const changed = (trace) => {
      this.sendLines(trace);
      this.host.saved?.();
    };
    $('lines-on').addEventListener('change', () => {
      l().on = $('lines-on').checked;
      if (l().on) this.sendLines(true);
      this.host.onModes();
    });
    $('points-on').addEventListener('change', () => {
      l().points = $('points-on').checked;
      if (l().points) this.sendPoints();
      this.host.onModes();
    });
    $('lines-seeds').addEventListener('change', () => {
      l().seeds = $('lines-seeds').value;
      l().count = l().seeds === 'rake' ? 100 : 12;
      this.retraced();
      this.show();
      changed(true);
    });
    $('lines-field').addEventListener('change', () => {
      l().field = $('lines-field').value || null;
      this.retraced();
      changed(true);
    });
    $('lines-count').addEventListener('change', () => {
      const count = Math.round(Number($('lines-count').value));
      l().count = l().seeds === 'rake' ? Math.min(2000, Math.max(1, count || 100)) : Math.min(64, Math.max(1, count || 12));
      this.retraced();
      changed(true);
    });
    for (const id of ['lines-from', 'lines-to']) {
      $(id).addEventListener('change', () => {
        const p = numbers($(id).value);
        if (p.length !== 3 || p.some((x) => !Number.isFinite(x))) return this.status('rake ends are x,y,z');
        l()[id === 'lines-from' ? 'from' : 'to'] = p;
        this.retraced();
        changed(true);
      });
    }
    $('lines-ghost').addEventListener('change', () => {
      l().ghost = Math.max(0.02, $('lines-ghost').value / 100);
      changed(false);
    });
    $('lines-flow').addEventListener('change', () => {
      l().flow = $('lines-flow').value;
      this.show();
      changed(false);
    });
    $('lines-animate').addEventListener('change', () => {
      l().animate = $('lines-animate').checked;
      this.host.saved?.();
    });
    $('lines-depth').addEventListener('change', () => {
      l().depth = $('lines-depth').value / 100;
      changed(false);
    });
    $('lines-clear').addEventListener('click', () => this.select(null));
    $('lines-box').addEventListener('change', () => {
      const b = numbers($('lines-box').value);
      if (b.length !== 6 || b.some((x) => !Number.isFinite(x))) return this.status('the box is x0,y0,z0,x1,y1,z1');
      this.select({ box: [b.slice(0, 3).map((x, k) => Math.min(x, b[k + 3])), b.slice(0, 3).map((x, k) => Math.max(x, b[k + 3]))] });
    });
    $('points-values').addEventListener('change', () => {
      l().pointValues = numbers($('points-values').value).filter(Number.isFinite).slice(0, 16);
      this.sendPoints();
      this.host.saved?.();
    });
    this.listenToImage();
    this.timer = setInterval(() => this.animate(), 1000 / kAnimationHz);
  }

  // new lines: picked ids and clicks meant lines of the old trace; a box still selects
  retraced() {
    if (!this.l().select?.box) this.l().select = null;
  }

  l() {
    const view = this.host.view();
    view.lines ??= defaultLines();
    return view.lines;
  }

  status(text) {
    this.$('lines-status').textContent = text;
  }

  // a click while picking selects a line, a drag while drawing makes a rake or a box; both
  // before the camera sees the press
  listenToImage() {
    const canvas = this.canvas, $ = this.$;
    const at = (e) => {
      const r = canvas.getBoundingClientRect();
      return [Math.min(1, Math.max(0, (e.clientX - r.left) / r.width)), Math.min(1, Math.max(0, (e.clientY - r.top) / r.height))];
    };
    let drag = null;  // {start, end, box}
    canvas.addEventListener(
      'pointerdown',
      (e) => {
        if (!this.l().on || !($('lines-pick').checked || $('lines-draw').checked)) return;
        e.stopImmediatePropagation();
        e.preventDefault();
        if ($('lines-draw').checked) {
          drag = { start: at(e), end: at(e), box: e.shiftKey };
          canvas.setPointerCapture?.(e.pointerId);
          this.drawOverlay(drag);
        } else {
          this.select({ pixel: at(e) });
        }
      },
      { capture: true },
    );
    canvas.addEventListener(
      'pointermove',
      (e) => {
        if (!drag) return;
        e.stopImmediatePropagation();
        drag.end = at(e);
        this.drawOverlay(drag);
      },
      { capture: true },
    );
    const finish = (e) => {
      if (!drag) return;
      e.stopImmediatePropagation();
      drag.end = at(e);
      const done = drag;
      drag = null;
      this.drawOverlay(null);
      this.placed(done);
    };
    canvas.addEventListener('pointerup', finish, { capture: true });
    canvas.addEventListener('pointercancel', () => {
      drag = null;
      this.drawOverlay(null);
    }, { capture: true });
  }

  // The rake or box shown while dragging: a canvas over the image, not in the frames.
  drawOverlay(drag) {
    if (!this.overlay) {
      this.overlay = document.createElement('canvas');
      this.overlay.id = 'lines-overlay';
      this.overlay.style.cssText = 'position:absolute;left:0;top:0;pointer-events:none';
      this.canvas.insertAdjacentElement('afterend', this.overlay);
    }
    const o = this.overlay, r = this.canvas.getBoundingClientRect();
    o.hidden = !drag;
    if (!drag) return;
    Object.assign(o.style, { left: `${this.canvas.offsetLeft}px`, top: `${this.canvas.offsetTop}px`, width: `${r.width}px`, height: `${r.height}px` });
    o.width = Math.round(r.width);
    o.height = Math.round(r.height);
    const g = o.getContext('2d');
    g.clearRect(0, 0, o.width, o.height);
    g.strokeStyle = '#ffd23f';
    g.lineWidth = 2;
    g.setLineDash(drag.box ? [6, 4] : []);
    const [x0, y0] = [drag.start[0] * o.width, drag.start[1] * o.height], [x1, y1] = [drag.end[0] * o.width, drag.end[1] * o.height];
    g.beginPath();
    if (drag.box) g.rect(Math.min(x0, x1), Math.min(y0, y1), Math.abs(x1 - x0), Math.abs(y1 - y0));
    else {
      g.moveTo(x0, y0);
      g.lineTo(x1, y1);
      for (const [x, y] of [[x0, y0], [x1, y1]]) g.moveTo(x + 4, y), g.arc(x, y, 4, 0, 2 * Math.PI);
    }
    g.stroke();
  }

  // A drag ended: the rake becomes the seeds (traced again), the box the selection.
  placed({ start, end, box }) {
    const camera = this.host.camera?.();
    if (!camera) return;
    const r = this.canvas.getBoundingClientRect();
    const aspect = r.width / r.height;
    if (Math.hypot((end[0] - start[0]) * r.width, (end[1] - start[1]) * r.height) < 4) return this.status('drag farther to draw');
    if (box) {
      const corners = [[start[0], start[1]], [end[0], start[1]], [start[0], end[1]], [end[0], end[1]]].map(([x, y]) => pointOnViewPlane(camera, aspect, x, y));
      const lo = [0, 1, 2].map((k) => Math.min(...corners.map((c) => c[k]))), hi = [0, 1, 2].map((k) => Math.max(...corners.map((c) => c[k])));
      // as deep along the view as the box is wide: a box around the plane
      const side = Math.max(...[0, 1, 2].map((k) => hi[k] - lo[k]));
      const eye = camera.eye, target = camera.target, d = Math.hypot(...target.map((t, k) => t - eye[k]));
      const forward = target.map((t, k) => (t - eye[k]) / d);
      const b = [lo.map((v, k) => v - Math.abs(forward[k]) * side / 2), hi.map((v, k) => v + Math.abs(forward[k]) * side / 2)];
      this.select({ box: b });
      return;
    }
    const l = this.l();
    Object.assign(l, {
      seeds: 'rake',
      from: pointOnViewPlane(camera, aspect, ...start),
      to: pointOnViewPlane(camera, aspect, ...end),
      count: l.seeds === 'rake' ? l.count : 100,
    });
    this.retraced();
    this.show();
    this.sendLines(true);
    this.host.saved?.();
  }

  setDataset(info) {
    const vectors = info.attributes.filter((a) => a.components === 3);
    this.$('lines-field').replaceChildren(...vectors.map((a) => new Option(a.name, a.name)));
    this.$('lines-on').disabled = vectors.length === 0;
    const l = this.l();
    if (!vectors.length) l.on = false;
    if (l.field && !vectors.some((a) => a.name === l.field)) Object.assign(l, { field: null, select: null });
    l.field ??= vectors[0]?.name ?? null;
    this.status(vectors.length ? '' : 'no vector field in this dataset');
    const b = info.bounds;
    if (b && !(l.from && l.to)) {  // a rake across the middle of the box, along its longest side
      const min = b.min ?? b[0], max = b.max ?? b[1];
      const mid = [0, 1, 2].map((k) => (min[k] + max[k]) / 2);
      const ext = [0, 1, 2].map((k) => max[k] - min[k]);
      const axis = ext.indexOf(Math.max(...ext));
      const from = [...mid], to = [...mid];
      from[axis] = min[axis] + 0.05 * ext[axis];
      to[axis] = max[axis] - 0.05 * ext[axis];
      Object.assign(l, { from, to });
    }
    this.show();
  }

  // view.lines -> the controls
  show() {
    const l = this.l(), $ = this.$;
    $('lines-on').checked = l.on;
    $('points-on').checked = l.points;
    if (l.field) $('lines-field').value = l.field;
    $('lines-seeds').value = l.seeds;
    $('lines-rake').hidden = l.seeds !== 'rake';
    $('lines-count').value = l.count;
    if (l.from) $('lines-from').value = fmt(l.from);
    if (l.to) $('lines-to').value = fmt(l.to);
    $('lines-ghost').value = Math.round(l.ghost * 100);
    $('lines-flow').value = l.flow;
    $('lines-animate-label').hidden = l.flow !== 'dashes';
    $('lines-animate').checked = l.animate;
    $('lines-depth').value = Math.round(l.depth * 100);
    $('lines-box').value = l.select?.box ? fmt([...l.select.box[0], ...l.select.box[1]]) : '';
    $('points-values').value = l.pointValues.map((x) => +x.toPrecision(5)).join(', ');
  }

  modes() {
    const l = this.l();
    return [...(l.on ? ['lines'] : []), ...(l.points ? ['points'] : [])];
  }

  active() {
    return this.modes().length > 0;
  }

  // lines.set; with `trace`, the field, seeds and selection too (the server traces again)
  sendLines(trace) {
    const l = this.l();
    const body = { ghost_opacity: l.ghost, flow: l.flow, depth_correction: l.depth };
    if (trace) {
      if (l.field) body.field = l.field;
      if (l.seeds === 'rake') {
        if (!l.from || !l.to) return this.status('rake ends are x,y,z');
        body.seeds = [l.from, l.to];
        body.count = Math.min(2000, Math.max(1, l.count));
      } else {
        body.seeds = 'dense';
        body.count = Math.min(64, Math.max(1, l.count));
      }
      body.select = l.select ?? {};
    }
    this.status('');
    this.send('lines.set', body);
  }

  select(selection) {
    this.l().select = selection;
    this.$('lines-box').value = selection?.box ? fmt([...selection.box[0], ...selection.box[1]]) : '';
    this.send('lines.set', { select: selection ?? {} });
    this.host.saved?.();
  }

  sendPoints() {
    const values = this.l().pointValues;
    this.send('points.set', values.length ? { values } : {});
  }

  sendAll() {
    this.step = null;
    if (this.l().on) this.sendLines(true);
    if (this.l().points) this.sendPoints();
  }

  // ---------- dash animation ----------

  onFrame(header) {
    if (this.step && header.message_id >= this.step.id) this.step = null;
  }

  animate() {
    const l = this.l();
    if (!l.on || l.flow !== 'dashes' || !l.animate || document.hidden) return;
    if (this.step && performance.now() - this.step.at < kStepTimeoutMs) return;  // the last step's frame first
    this.phase = (this.phase + kPhaseStep) % 1;
    const id = this.send('lines.set', { dash_phase: this.phase });
    this.step = id > 0 ? { id, at: performance.now() } : null;
  }
}
