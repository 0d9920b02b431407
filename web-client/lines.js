// Stream lines (§7.3) and point isosurfaces (§7.2) in the viewer: a panel of its own (built
// here, appended to the side panel) that sends lines.set and points.set, and adds "lines" and
// "points" to the mode the app sends.
//   const panel = new LinesPanel(container, canvas, { send, onModes });
//   panel.setDataset(info)   the dataset's vector fields fill the field list
//   panel.modes()            ['lines'] / ['points'] / both, for mode.set
//   panel.sendAll()          lines.set and points.set for the current controls (after a dataset opens)
// A click on the image while "pick" is on selects the line under it (opaque, the others
// ghosted); the seed box selects the lines through it; "clear" shows every line opaque.

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
    <label>Ghosts <input type="range" id="lines-ghost" min="2" max="100" value="15"></label>
    <label>Flow <select id="lines-flow"><option>arrows</option><option>dashes</option><option>none</option></select></label>
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

export class LinesPanel {
  constructor(container, canvas, { send, onModes }) {
    container.insertAdjacentHTML('beforeend', html);
    this.send = send;
    this.onModes = onModes;
    this.canvas = canvas;
    this.$ = (id) => container.querySelector(`#${id}`);
    const $ = this.$;
    $('lines-on').addEventListener('change', () => {
      if ($('lines-on').checked) this.sendLines(true);
      this.onModes();
    });
    $('points-on').addEventListener('change', () => {
      if ($('points-on').checked) this.sendPoints();
      this.onModes();
    });
    $('lines-seeds').addEventListener('change', () => {
      $('lines-rake').hidden = $('lines-seeds').value !== 'rake';
      $('lines-count').value = $('lines-seeds').value === 'rake' ? 100 : 12;
      this.sendLines(true);
    });
    for (const id of ['lines-field', 'lines-count', 'lines-from', 'lines-to']) $(id).addEventListener('change', () => this.sendLines(true));
    $('lines-ghost').addEventListener('change', () => this.sendLines(false));
    $('lines-flow').addEventListener('change', () => this.sendLines(false));
    $('lines-clear').addEventListener('click', () => this.select({}));
    $('lines-box').addEventListener('change', () => {
      const b = numbers($('lines-box').value);
      if (b.length !== 6 || b.some((x) => !Number.isFinite(x))) return this.status('the box is x0,y0,z0,x1,y1,z1');
      this.select({ box: [b.slice(0, 3).map((x, k) => Math.min(x, b[k + 3])), b.slice(0, 3).map((x, k) => Math.max(x, b[k + 3]))] });
    });
    $('points-values').addEventListener('change', () => this.sendPoints());
    // a click while picking selects a line, before the camera sees the press
    canvas.addEventListener(
      'pointerdown',
      (e) => {
        if (!$('lines-pick').checked || !$('lines-on').checked) return;
        e.stopImmediatePropagation();
        e.preventDefault();
        const r = canvas.getBoundingClientRect();
        const x = Math.min(1, Math.max(0, (e.clientX - r.left) / r.width));
        const y = Math.min(1, Math.max(0, (e.clientY - r.top) / r.height));
        this.select({ pixel: [x, y] });
      },
      { capture: true },
    );
  }

  status(text) {
    this.$('lines-status').textContent = text;
  }

  setDataset(info) {
    const vectors = info.attributes.filter((a) => a.components === 3);
    this.$('lines-field').replaceChildren(...vectors.map((a) => new Option(a.name, a.name)));
    this.$('lines-on').disabled = vectors.length === 0;
    if (!vectors.length) this.$('lines-on').checked = false;
    this.status(vectors.length ? '' : 'no vector field in this dataset');
    const b = info.bounds;
    if (b) {  // a rake across the middle of the box, along its longest side
      const min = b.min ?? b[0], max = b.max ?? b[1];
      const mid = [0, 1, 2].map((k) => (min[k] + max[k]) / 2);
      const ext = [0, 1, 2].map((k) => max[k] - min[k]);
      const axis = ext.indexOf(Math.max(...ext));
      const from = [...mid], to = [...mid];
      from[axis] = min[axis] + 0.05 * ext[axis];
      to[axis] = max[axis] - 0.05 * ext[axis];
      this.$('lines-from').value = from.map((x) => +x.toPrecision(4)).join(',');
      this.$('lines-to').value = to.map((x) => +x.toPrecision(4)).join(',');
    }
  }

  modes() {
    return [...(this.$('lines-on').checked ? ['lines'] : []), ...(this.$('points-on').checked ? ['points'] : [])];
  }

  active() {
    return this.modes().length > 0;
  }

  // lines.set; with `trace`, the field and seeds too (the server traces again)
  sendLines(trace) {
    const $ = this.$;
    const body = { ghost_opacity: Math.max(0.02, $('lines-ghost').value / 100), flow: $('lines-flow').value };
    if (trace) {
      if ($('lines-field').value) body.field = $('lines-field').value;
      const count = Math.round(Number($('lines-count').value));
      if ($('lines-seeds').value === 'rake') {
        const from = numbers($('lines-from').value), to = numbers($('lines-to').value);
        if (from.length !== 3 || to.length !== 3 || [...from, ...to].some((x) => !Number.isFinite(x))) return this.status('rake ends are x,y,z');
        body.seeds = [from, to];
        body.count = Math.min(2000, Math.max(1, count || 100));
      } else {
        body.seeds = 'dense';
        body.count = Math.min(64, Math.max(1, count || 12));
      }
      body.select = {};
    }
    this.status('');
    this.send('lines.set', body);
  }

  select(selection) {
    this.send('lines.set', { select: selection });
  }

  sendPoints() {
    const values = numbers(this.$('points-values').value).filter(Number.isFinite).slice(0, 16);
    this.send('points.set', values.length ? { values } : {});
  }

  sendAll() {
    if (this.$('lines-on').checked) this.sendLines(true);
    if (this.$('points-on').checked) this.sendPoints();
  }
}
