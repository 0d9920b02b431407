// Clip and slice planes in the viewer: add and remove planes, pick a normal (±X, ±Y, ±Z or
// the view direction), drag a plane along its normal with its slider, invert a clip, show
// the tets' edges on slices, slices lit or flat. The planes live in the view (view.clips,
// view.slices, view.sliceEdges, view.sliceFlat), travel in the URL (clip=, slice=, sedges=,
// sflat=) and go to the server as clip.set and slice.set (protocol/js/planes.js checks them).

// protocol/js/planes.js's limits (not imported: view-state.js, which imports this module,
// also runs under node, where /protocol/ does not resolve)
const MAX_CLIP_PLANES = 6;
const MAX_SLICE_PLANES = 6;
const NORMALS = { '+x': [1, 0, 0], '-x': [-1, 0, 0], '+y': [0, 1, 0], '-y': [0, -1, 0], '+z': [0, 0, 1], '-z': [0, 0, -1] };
const SLIDER_STEPS = 1000;

const num = (x) => String(+(+x).toPrecision(6));

// ---------- the URL ----------

// "nx:ny:nz:d" planes joined by ",", a clip plane's ":i" when inverted.
export function planesToHash(view) {
  const p = [];
  const plane = (q) => [...q.normal, q.offset].map(num).join(':') + (q.invert ? ':i' : '');
  if (view.clips?.length) p.push(`clip=${view.clips.map(plane).join(',')}`);
  if (view.slices?.length) p.push(`slice=${view.slices.map(plane).join(',')}`);
  if (view.sliceEdges) p.push('sedges=1');
  if (view.sliceFlat) p.push('sflat=1');
  return p;
}

// Untrusted (a pasted link): a malformed plane is dropped, as are planes past the limits.
export function planesFromHash(h) {
  const parse = (text, clip, max) => {
    const out = [];
    for (const part of (text ?? '').split(',')) {
      const f = part.split(':');
      const invert = clip && f.length === 5 && f[4] === 'i';
      if (f.length !== 4 && !invert) continue;
      const v = f.slice(0, 4).map((s) => (s === '' ? NaN : Number(s)));
      if (!v.every(Number.isFinite) || !(Math.hypot(v[0], v[1], v[2]) > 0) || v.some((x) => Math.abs(x) > 1e30)) continue;
      out.push({ normal: v.slice(0, 3), offset: v[3], ...(clip ? { invert } : {}) });
    }
    return out.slice(0, max);
  };
  return { clips: parse(h.get('clip'), true, MAX_CLIP_PLANES), slices: parse(h.get('slice'), false, MAX_SLICE_PLANES), sliceEdges: h.get('sedges') === '1', sliceFlat: h.get('sflat') === '1' };
}

export const clipBody = (view) => ({ planes: (view.clips ?? []).map(({ normal, offset, invert }) => ({ normal, offset, invert: !!invert })) });
export const sliceBody = (view) => ({ planes: (view.slices ?? []).map(({ normal, offset }) => ({ normal, offset })), edges: !!view.sliceEdges, lit: !view.sliceFlat });

// ---------- the panel ----------

export class PlanesPanel {
  // host: { send(type, body), view(), bounds() -> {min, max} | null, viewDirection() -> [x, y, z] | null, saved() }
  constructor(root, host) {
    this.root = root;
    this.host = host;
    this.pending = { clip: false, slice: false };
    root.querySelector('[data-add=clip]').addEventListener('click', () => this.add('clips'));
    root.querySelector('[data-add=slice]').addEventListener('click', () => this.add('slices'));
    root.querySelector('#slice-edges').addEventListener('change', (e) => {
      this.host.view().sliceEdges = e.target.checked;
      this.sendSlices();
      this.host.saved();
    });
    root.querySelector('#slice-lit').addEventListener('change', (e) => {
      this.host.view().sliceFlat = !e.target.checked;
      this.sendSlices();
      this.host.saved();
    });
  }

  // the dataset's centre and half diagonal: where a new plane goes and how far it may move
  extent() {
    const b = this.host.bounds();
    if (!b) return { centre: [0, 0, 0], radius: 1 };
    const centre = b.min.map((v, i) => (v + b.max[i]) / 2);
    return { centre, radius: Math.max(1e-30, Math.hypot(...b.max.map((v, i) => v - b.min[i])) / 2) };
  }

  add(kind) {
    const view = this.host.view();
    const list = (view[kind] ??= []);
    if (list.length >= (kind === 'clips' ? MAX_CLIP_PLANES : MAX_SLICE_PLANES)) return;
    const normal = kind === 'clips' ? [1, 0, 0] : [0, 0, 1];
    const { centre } = this.extent();
    list.push({ normal, offset: normal.reduce((s, n, i) => s + n * centre[i], 0), ...(kind === 'clips' ? { invert: false } : {}) });
    this.show();
    this.changed(kind, false);
  }

  remove(kind, index) {
    this.host.view()[kind].splice(index, 1);
    this.show();
    this.changed(kind, false);
  }

  // a new normal keeps the plane through the same point of the centre line
  setNormal(kind, index, normal) {
    const plane = this.host.view()[kind][index];
    const { centre } = this.extent();
    const along = plane.offset - plane.normal.reduce((s, n, i) => s + n * centre[i], 0);
    const length = Math.hypot(...normal);
    plane.normal = normal.map((n) => n / length);
    plane.offset = plane.normal.reduce((s, n, i) => s + n * centre[i], 0) + along;
    this.show();
    this.changed(kind, false);
  }

  // Rebuilds the rows from the view.
  show() {
    const view = this.host.view();
    this.root.querySelector('#slice-edges').checked = !!view.sliceEdges;
    this.root.querySelector('#slice-lit').checked = !view.sliceFlat;
    const rows = this.root.querySelector('.plane-rows');
    rows.replaceChildren();
    for (const kind of ['clips', 'slices'])
      (view[kind] ?? []).forEach((plane, index) => rows.append(this.row(kind, plane, index)));
    for (const [kind, max] of [['clip', MAX_CLIP_PLANES], ['slice', MAX_SLICE_PLANES]])
      this.root.querySelector(`[data-add=${kind}]`).disabled = (view[`${kind}s`] ?? []).length >= max;
  }

  row(kind, plane, index) {
    const row = document.createElement('div');
    row.className = 'plane-row';
    row.dataset.kind = kind;
    row.dataset.index = index;
    const label = Object.assign(document.createElement('span'), { textContent: `${kind === 'clips' ? 'clip' : 'slice'} ${index + 1}`, className: 'small' });
    const normal = document.createElement('select');
    normal.className = 'plane-normal';
    normal.setAttribute('aria-label', 'normal');
    const current = Object.entries(NORMALS).find(([, n]) => n.every((c, i) => Math.abs(c - plane.normal[i]) < 1e-9))?.[0] ?? 'custom';
    for (const key of [...Object.keys(NORMALS), 'view', ...(current === 'custom' ? ['custom'] : [])])
      normal.append(new Option(key === 'view' ? 'view direction' : key === 'custom' ? plane.normal.map((c) => c.toFixed(2)).join(', ') : key.toUpperCase(), key));
    normal.value = current;
    normal.addEventListener('change', () => {
      const n = normal.value === 'view' ? this.host.viewDirection() : NORMALS[normal.value];
      if (n) this.setNormal(kind, index, n);
    });
    // the slider: the plane's offset about the centre, over the box's half diagonal
    const { centre, radius } = this.extent();
    const base = plane.normal.reduce((s, n, i) => s + n * centre[i], 0);
    const slider = Object.assign(document.createElement('input'), { type: 'range', min: -SLIDER_STEPS, max: SLIDER_STEPS, className: 'plane-offset' });
    slider.setAttribute('aria-label', 'position along the normal');
    slider.value = String(Math.round(((plane.offset - base) / radius) * SLIDER_STEPS));
    slider.addEventListener('input', () => {
      plane.offset = base + (Number(slider.value) / SLIDER_STEPS) * radius;
      this.changed(kind, true);
    });
    slider.addEventListener('change', () => this.host.saved());
    row.append(label, normal, slider);
    if (kind === 'clips') {
      const invert = Object.assign(document.createElement('input'), { type: 'checkbox', checked: !!plane.invert, title: 'keep the other side' });
      invert.className = 'plane-invert';
      invert.addEventListener('change', () => {
        plane.invert = invert.checked;
        this.changed(kind, false);
      });
      const wrap = document.createElement('label');
      wrap.append(invert, ' flip');
      row.append(wrap);
    }
    const remove = Object.assign(document.createElement('button'), { textContent: '×', title: 'remove', className: 'plane-remove' });
    remove.addEventListener('click', () => this.remove(kind, index));
    row.append(remove);
    return row;
  }

  // a drag sends at most one message per animation frame
  changed(kind, dragging) {
    const key = kind === 'clips' ? 'clip' : 'slice';
    if (!dragging) {
      this.send(key);
      this.host.saved();
      return;
    }
    if (this.pending[key]) return;
    this.pending[key] = true;
    requestAnimationFrame(() => {
      this.pending[key] = false;
      this.send(key);
    });
  }

  send(key) {
    if (key === 'clip') this.sendClips();
    else this.sendSlices();
  }

  sendClips() {
    this.host.send('clip.set', clipBody(this.host.view()));
  }

  sendSlices() {
    this.host.send('slice.set', sliceBody(this.host.view()));
  }

  // after a (re)connect or a dataset change
  sendAll() {
    const view = this.host.view();
    if (view.clips?.length) this.sendClips();
    if (view.slices?.length || view.sliceEdges || view.sliceFlat) this.sendSlices();
  }
}
