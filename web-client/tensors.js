// Tensor fields (§7.4.2) in the viewer: a panel of its own (built here, appended to the side
// panel) that sends tensors.set and adds "tensors" to the mode the app sends: stream tubes
// along the major eigenvector in linear regions and diffusion surfaces in planar ones, drawn
// by the server as lit points. What the panel shows lives in the view (view.tensors), so it
// travels in the URL and is sent again after a reconnect.
//   const panel = new TensorsPanel(container, { send, onModes, view, saved });
//   panel.setDataset(info)   the dataset's tensor attributes (dataset.info kind "tensor") fill the field list
//   panel.modes()            ['tensors'] or [], for mode.set
//   panel.sendAll()          tensors.set for the view
//   panel.legend(info, table) the legend of what colours the points: the classes, or a derived quantity's colour bar

export const TENSOR_QUANTITIES = ['lambda1', 'lambda2', 'lambda3', 'trace', 'von_mises', 'fa', 'cl', 'cp', 'cs'];
// the renderer's class colours (render.h kAnisotropyColors), by class: isotropic, linear, planar
export const ANISOTROPY_CLASSES = [
  { label: 'linear (tubes)', color: [0.92, 0.22, 0.18] },
  { label: 'planar (surfaces)', color: [0.2, 0.78, 0.3] },
  { label: 'isotropic', color: [0.25, 0.45, 0.95] },
];
const kMaxCells = 32;

export function defaultTensors() {
  return { on: false, field: null, density: 8, surfaces: 3, color: 'class', size: 0 };
}

// Keys: tfield, tdensity, tsurf, tcolor, tsize; "tensors" goes in mode=.
export function tensorsToHash(view) {
  const t = view.tensors ?? defaultTensors(), d = defaultTensors(), p = [];
  const put = (k, v) => p.push(`${k}=${encodeURIComponent(v)}`);
  if (t.field) put('tfield', t.field);
  if (t.density !== d.density) put('tdensity', t.density);
  if (t.surfaces !== d.surfaces) put('tsurf', t.surfaces);
  if (t.color !== d.color) put('tcolor', t.color);
  if (t.size) put('tsize', t.size);
  return p;
}

// Untrusted (a pasted link): a malformed field is dropped, the default stays.
export function tensorsFromHash(h, modes = []) {
  const t = defaultTensors();
  t.on = modes.includes('tensors');
  const field = h.get('tfield') ?? '';
  if (/^[^\s]{1,128}$/.test(field)) t.field = field;
  const cells = (key) => {
    const s = h.get(key) ?? '';
    return /^\d{1,2}$/.test(s) && Number(s) <= kMaxCells ? Number(s) : null;
  };
  t.density = cells('tdensity') ?? t.density;
  t.surfaces = cells('tsurf') ?? t.surfaces;
  if (['class', ...TENSOR_QUANTITIES].includes(h.get('tcolor'))) t.color = h.get('tcolor');
  const size = Number(h.get('tsize'));
  if (h.get('tsize') && Number.isFinite(size) && size >= 0 && size <= 64) t.size = size;
  return t;
}

const html = `
<div class="tensors-panel">
  <div class="row">
    <label><input type="checkbox" id="tensors-on"> tubes and surfaces</label>
  </div>
  <label>Tensor <select id="tensors-field"></select></label>
  <div class="row">
    <label title="tube seeds: grid cells along the box's longest side, a seed a cell (0: no tubes)">Tubes <input type="number" id="tensors-density" min="0" max="${kMaxCells}" value="8" style="width:4em"></label>
    <label title="diffusion-surface seeds, likewise (0: no surfaces)">Surfaces <input type="number" id="tensors-surfaces" min="0" max="${kMaxCells}" value="3" style="width:4em"></label>
  </div>
  <div class="row">
    <label>Colour <select id="tensors-color">
      <option value="class">anisotropy class</option>
      ${TENSOR_QUANTITIES.map((q) => `<option value="${q}">${q}</option>`).join('')}
    </select></label>
    <label title="splat diameter in pixels; 0: covering">Points <input type="number" id="tensors-size" min="0" max="64" value="0" style="width:4em"> px</label>
  </div>
  <div class="tensors-status" id="tensors-status"></div>
</div>`;

export class TensorsPanel {
  // host: { send(type, body) -> id, onModes(), view() -> the view, saved() }
  constructor(container, host) {
    container.insertAdjacentHTML('beforeend', html);
    this.host = host;
    this.$ = (id) => container.querySelector(`#${id}`);
    const $ = this.$;
    const t = () => this.t();
    const changed = () => {
      this.send();
      this.host.saved?.();
      this.host.onLegend?.();
    };
    $('tensors-on').addEventListener('change', () => {
      t().on = $('tensors-on').checked;
      if (t().on) this.send();
      this.host.onModes();
    });
    $('tensors-field').addEventListener('change', () => {
      t().field = $('tensors-field').value || null;
      changed();
    });
    const cells = (id, key, fallback) =>
      $(id).addEventListener('change', () => {
        const n = Math.round(Number($(id).value));
        t()[key] = Number.isFinite(n) ? Math.min(kMaxCells, Math.max(0, n)) : fallback;
        $(id).value = t()[key];
        changed();
      });
    cells('tensors-density', 'density', 8);
    cells('tensors-surfaces', 'surfaces', 3);
    $('tensors-color').addEventListener('change', () => {
      t().color = $('tensors-color').value;
      changed();
    });
    $('tensors-size').addEventListener('change', () => {
      const n = Number($('tensors-size').value);
      t().size = Number.isFinite(n) ? Math.min(64, Math.max(0, n)) : 0;
      changed();
    });
  }

  t() {
    const view = this.host.view();
    view.tensors ??= defaultTensors();
    return view.tensors;
  }

  setDataset(info) {
    const tensors = info.attributes.filter((a) => a.kind === 'tensor');
    this.$('tensors-field').replaceChildren(...tensors.map((a) => new Option(a.name, a.name)));
    this.$('tensors-on').disabled = tensors.length === 0;
    const t = this.t();
    if (!tensors.length) t.on = false;
    if (t.field && !tensors.some((a) => a.name === t.field)) t.field = null;
    t.field ??= tensors[0]?.name ?? null;
    this.$('tensors-status').textContent = tensors.length ? '' : 'no tensor field in this dataset';
    this.show();
  }

  show() {
    const t = this.t(), $ = this.$;
    $('tensors-on').checked = t.on;
    if (t.field) $('tensors-field').value = t.field;
    $('tensors-density').value = t.density;
    $('tensors-surfaces').value = t.surfaces;
    $('tensors-color').value = t.color;
    $('tensors-size').value = t.size;
  }

  modes() {
    return this.t().on ? ['tensors'] : [];
  }

  send() {
    const t = this.t();
    const body = { density: t.density, surface_density: t.surfaces, color: t.color, size: t.size };
    if (t.field) body.field = t.field;
    this.host.send('tensors.set', body);
  }

  sendAll() {
    if (this.t().on) this.send();
  }

  // The legend of the points (null when they are off): the anisotropy classes, or the derived
  // quantity over its range over the dataset (dataset.info's "FIELD.QUANTITY"), in `colors`.
  legend(info, colors) {
    const t = this.t();
    if (!t.on || !t.field || !info) return null;
    if (t.color === 'class') return { key: 'tensors', title: `${t.field} — anisotropy`, caption: 'tensor points', classes: ANISOTROPY_CLASSES };
    const derived = info.attributes.find((a) => a.name === `${t.field}.${t.color}`);
    if (!derived) return null;
    const range = derived.range[1] > derived.range[0] ? derived.range : [derived.range[0], derived.range[0] + 1];
    return { key: 'tensors', title: `${t.field}.${t.color}`, caption: 'tensor points', colors, range, log: false };
  }
}
