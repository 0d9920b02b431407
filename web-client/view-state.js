// The whole view a page shows, as one plain object: what the URL carries (so a link
// reopens the same image) and what is sent again after every reconnect. Colour and opacity
// points are kept in normalised units t in [0, 1] over the range, so a new range keeps the
// curve's shape; tfBody() maps them onto attribute values for tf.set.
import { DEFAULT_PRESET, PRESETS, colorAt } from './colormaps.js';
import { defaultLines, linesFromHash, linesToHash } from './lines.js';
import { defaultTensors, tensorsFromHash, tensorsToHash } from './tensors.js';
import { planesFromHash, planesToHash } from './planes.js';
import { regionsFromHash, regionsToHash } from './regions.js';
import { timeFromHash, timeToHash } from './time.js';

// The default opacity curve, chosen by looking at the shared datasets (disk_out_ref,
// fea_bracket, nasa_bluntfin, freefem_leman, onera_m6, nasa_combustion_chamber,
// nasa_oxygen_post) in the viewer: the lower half nearly transparent, rising to 0.3. A ramp
// to 1 turns them into a solid can (disk_out_ref) or a fog (bluntfin); this shows the
// reactor's inner band through its can and the fin's shock through the flow. Datasets in a
// large far-field box (onera_m6, oxygen_post) need a smaller unit distance as well.
export const DEFAULT_OPACITY = Object.freeze([[0, 0], [0.5, 0.05], [1, 0.3]]);

// Counts of `histogram` (bins evenly over histogramRange) re-binned onto `bins` bins over
// `range`, each source bin spread evenly over its own span.
export function rebin(histogram, histogramRange, range, bins) {
  const out = new Array(bins).fill(0);
  const [hlo, hhi] = histogramRange, [lo, hi] = range;
  const width = (hhi - hlo) / histogram.length;
  if (!(width > 0) || !(hi > lo)) return out;
  histogram.forEach((count, b) => {
    const a0 = hlo + b * width, a1 = a0 + width;
    const first = Math.max(0, Math.floor(((a0 - lo) / (hi - lo)) * bins)), last = Math.min(bins - 1, Math.floor(((a1 - lo) / (hi - lo)) * bins));
    for (let k = first; k <= last; ++k) {
      const b0 = lo + ((hi - lo) * k) / bins, b1 = lo + ((hi - lo) * (k + 1)) / bins;
      const overlap = Math.min(a1, b1) - Math.max(a0, b0);
      if (overlap > 0) out[k] += (count * overlap) / width;
    }
  });
  return out;
}

// The opacity points shown and sent: the user's, else the default.
export function effectiveOpacity(view) {
  return view.opacity ?? DEFAULT_OPACITY.map((p) => [...p]);
}

export function defaultView() {
  return {
    dataset: null,
    attribute: null,
    component: 'magnitude',     // of a vector attribute: 'magnitude', 'x', 'y' or 'z' (tf.set component)
    camera: null,               // {eye, target, up, fov}; null: the dataset's opening view
    preset: DEFAULT_PRESET,
    colors: PRESETS[DEFAULT_PRESET].map((p) => [...p]),
    customColors: false,        // colours edited away from the preset
    opacity: null,              // [[t, alpha], ...]; null: DEFAULT_OPACITY
    range: null,                // [lo, hi]; null: the attribute's whole range
    opacityScale: 1,
    unitDistance: null,         // world units; null: the renderer's (1/100 of the box diagonal)
    outsideTransparent: false,  // else values outside the range take the end colours (ParaView)
    background: null,           // [r, g, b] in [0, 1]; null: the renderer's dark grey
    logScale: false,            // colours over log10 of the range (logScale(): only where it is above 0)
    legendTitles: {},           // legend key -> the title the user gave it (overlays.js showLegends)
    dvr: true, iso: false, surface: false, wireframe: false, box: false,
    isovalues: [],              // attribute units; empty: mid-range
    isoOpacity: 1,
    isoColorBy: null,           // an attribute colouring the isosurfaces; null: their value
    budget: null, interactionBudget: null,  // null: the server's
    interactionQuality: 60, stillQuality: 90, pngStills: false,
    clips: [], slices: [], sliceEdges: false, sliceFlat: false,  // planes.js
    lines: defaultLines(),      // stream lines and point isosurfaces (lines.js)
    tensors: defaultTensors(),  // a tensor field's tubes and surfaces (tensors.js)
    hiddenRegions: [],          // boundary regions left out (regions.js)
    timeStep: 0,                // a time series' step shown (time.js)
  };
}

// Forgets what belongs to one dataset (another one is opened).
export function forDataset(view, name) {
  const lines = { ...(view.lines ?? defaultLines()), field: null, from: null, to: null, select: null };
  const tensors = { ...(view.tensors ?? defaultTensors()), field: null };
  return { ...view, dataset: name, attribute: null, component: 'magnitude', camera: null, range: null, isovalues: [], unitDistance: null, clips: [], slices: [], lines, tensors, legendTitles: {}, isoColorBy: null, hiddenRegions: [], timeStep: 0 };
}

// ---------- what of an attribute is drawn ----------

// protocol/js/codec.js's COMPONENTS (not imported: this module also runs under node, where
// /protocol/ does not resolve)
const COMPONENTS = ['magnitude', 'x', 'y', 'z'];

// The components a vector attribute offers (its magnitude and x, y, z up to its own count);
// a scalar: none to choose.
export function componentsOf(attribute) {
  if (!attribute || attribute.components < 2) return [];
  return ['magnitude', ...COMPONENTS.slice(1, 1 + Math.min(attribute.components, 3))];
}

// The colour range of what is drawn: a component's over the dataset (dataset.info
// component_ranges), else the attribute's (a vector's magnitude); never empty.
export function rangeOfDrawn(attribute, component) {
  const k = COMPONENTS.indexOf(component) - 1;
  // a time series: over every step (series_range), so that colours stay put while it plays
  const r = k >= 0 && attribute?.component_ranges?.[k] ? attribute.component_ranges[k] : attribute?.series_range ?? attribute?.range;
  if (!r) return null;
  return r[1] > r[0] ? [...r] : [r[0], r[0] + 1];
}

// The histogram of what is drawn, over rangeOfDrawn.
export function histogramOfDrawn(attribute, component) {
  const k = COMPONENTS.indexOf(component) - 1;
  return k >= 0 ? attribute?.component_histograms?.[k] : attribute?.histogram;
}

// The name a legend gives what is drawn: "velocity X", "velocity Magnitude" (ParaView's), or
// a scalar's name.
export function drawnName(attribute, component) {
  if (!attribute || attribute.components < 2) return attribute?.name ?? '';
  const c = COMPONENTS.includes(component) ? component : 'magnitude';
  return `${attribute.name} ${c === 'magnitude' ? 'Magnitude' : c.toUpperCase()}`;
}

// ---------- URL fragment ----------

const kLegendKeys = ['attribute', 'iso', 'lines', 'tensors'];

const num = (x) => String(+(+x).toPrecision(6));
const list = (v) => v.map(num).join(',');
const hex = (v) => Math.round(v * 255).toString(16).padStart(2, '0');
// keep , : + readable; encode the rest a fragment value cannot hold
const enc = (s) => encodeURIComponent(s).replace(/%2C/g, ',').replace(/%3A/g, ':').replace(/%2B/g, '+');

export function viewToHash(view) {
  const p = [];
  const put = (key, value) => value !== undefined && value !== null && value !== '' && p.push(`${key}=${enc(String(value))}`);
  put('dataset', view.dataset);
  put('attribute', view.attribute);
  if (view.component && view.component !== 'magnitude') put('component', view.component);
  if (view.camera) {
    put('eye', list(view.camera.eye));
    put('target', list(view.camera.target));
    put('up', list(view.camera.up));
    put('fov', num(view.camera.fov));
    if (view.camera.orthographic) put('ortho', 1);
  }
  put('cmap', view.preset);
  if (view.customColors) put('colors', view.colors.map(([t, r, g, b]) => `${num(t)}:${hex(r)}${hex(g)}${hex(b)}`).join(','));
  if (view.opacity) put('opacity', view.opacity.map(([t, a]) => `${num(t)}:${num(a)}`).join(','));
  if (view.range) put('range', list(view.range));
  if (view.opacityScale !== 1) put('oscale', num(view.opacityScale));
  if (view.unitDistance) put('unit', num(view.unitDistance));
  if (view.outsideTransparent) put('outside', 'transparent');
  if (view.logScale) put('log', 1);
  if (view.background) put('bg', view.background.map(hex).join(''));
  for (const [key, title] of Object.entries(view.legendTitles ?? {})) if (title && kLegendKeys.includes(key)) put(`title.${key}`, title);
  put('mode', [...['dvr', 'iso', 'surface'].filter((m) => view[m]), ...(view.lines?.on ? ['lines'] : []), ...(view.lines?.points ? ['points'] : []), ...(view.tensors?.on ? ['tensors'] : [])].join('+') || 'slice');
  if (view.wireframe) put('wireframe', 1);
  if (view.box) put('box', 1);
  if (view.isovalues.length) put('iso', list(view.isovalues));
  if (view.isoOpacity !== 1) put('isoopacity', num(view.isoOpacity));
  put('isocolor', view.isoColorBy);
  if (view.budget) put('budget', view.budget);
  if (view.interactionBudget) put('ibudget', view.interactionBudget);
  put('quality', `${view.interactionQuality},${view.stillQuality}${view.pngStills ? ',png' : ''}`);
  p.push(...planesToHash(view));
  p.push(...linesToHash(view));
  p.push(...tensorsToHash(view));
  p.push(...regionsToHash(view));
  p.push(...timeToHash(view));
  return p.join('&');
}

// Untrusted (a pasted link): anything malformed is dropped, the default stays.
export function viewFromHash(hash) {
  const view = defaultView();
  const h = new Map();
  for (const part of hash.replace(/^#/, '').split('&')) {
    const eq = part.indexOf('=');
    if (eq <= 0) continue;
    try {
      h.set(part.slice(0, eq), decodeURIComponent(part.slice(eq + 1)));
    } catch {
      // a broken escape: skip the field
    }
  }
  const finite = (s) => s !== undefined && s !== '' && Number.isFinite(Number(s));
  const numbers = (key, n) => {
    const v = h.get(key)?.split(',');
    return v && (n === undefined || v.length === n) && v.every(finite) ? v.map(Number) : null;
  };
  const pairs = (key, parse) => {
    const v = h.get(key)?.split(',').map((s) => s.split(':'));
    if (!v || v.length < 2 || v.length > 64) return null;
    const out = v.map(parse);
    if (out.some((p) => !p) || out.some((p, i) => i && p[0] < out[i - 1][0])) return null;
    return out;
  };
  const name = (key) => (/^[A-Za-z0-9_.-]{1,128}$/.test(h.get(key) ?? '') ? h.get(key) : null);
  view.dataset = name('dataset');
  view.attribute = h.get('attribute')?.slice(0, 128) || null;
  if (COMPONENTS.includes(h.get('component'))) view.component = h.get('component');
  const eye = numbers('eye', 3), target = numbers('target', 3), up = numbers('up', 3);
  if (eye && target) {
    view.camera = { eye, target, up: up ?? [0, 1, 0], fov: Math.min(Math.max(Number(h.get('fov')) || 30, 1), 170) };
    if (h.get('ortho') === '1') view.camera.orthographic = true;
  }
  if (PRESETS[h.get('cmap')]) {
    view.preset = h.get('cmap');
    view.colors = PRESETS[view.preset].map((p) => [...p]);
  }
  const colors = pairs('colors', ([t, c]) => (finite(t) && /^[0-9a-fA-F]{6}$/.test(c ?? '') ? [Number(t), ...[0, 2, 4].map((i) => parseInt(c.slice(i, i + 2), 16) / 255)] : null));
  if (colors) Object.assign(view, { colors, customColors: true });
  const unit = (t) => Math.min(Math.max(Number(t), 0), 1);
  const opacity = pairs('opacity', ([t, a]) => (finite(t) && finite(a) ? [unit(t), unit(a)] : null));
  if (opacity) view.opacity = opacity;
  const range = numbers('range', 2);
  if (range && range[1] > range[0]) view.range = range;
  if (finite(h.get('oscale'))) view.opacityScale = Math.min(Math.max(Number(h.get('oscale')), 0), 3);
  if (finite(h.get('unit')) && Number(h.get('unit')) > 0) view.unitDistance = Number(h.get('unit'));
  view.outsideTransparent = h.get('outside') === 'transparent';
  view.logScale = h.get('log') === '1';
  if (/^[0-9a-fA-F]{6}$/.test(h.get('bg') ?? '')) view.background = [0, 2, 4].map((i) => parseInt(h.get('bg').slice(i, i + 2), 16) / 255);
  for (const key of kLegendKeys) if (h.get(`title.${key}`)) view.legendTitles[key] = h.get(`title.${key}`).slice(0, 200);
  const modes = h.get('mode')?.split('+') ?? [];
  view.lines = linesFromHash(h, modes);
  view.tensors = tensorsFromHash(h, modes);
  // 'slice': none of the others (the slice planes alone); a mode of nothing known keeps the default
  const known = ['dvr', 'iso', 'surface', 'lines', 'points', 'tensors', 'slice'];
  if (h.has('mode') && modes.some((m) => known.includes(m))) for (const m of ['dvr', 'iso', 'surface']) view[m] = modes.includes(m);
  view.wireframe = h.get('wireframe') === '1';
  view.box = h.get('box') === '1';
  view.isovalues = (numbers('iso') ?? []).slice(0, 16);
  view.isoColorBy = h.get('isocolor')?.slice(0, 128) || null;
  if (finite(h.get('isoopacity'))) view.isoOpacity = Math.min(Math.max(Number(h.get('isoopacity')), 0.05), 1);
  const whole = (key) => (/^\d{1,10}$/.test(h.get(key) ?? '') && Number(h.get(key)) >= 1 ? Number(h.get(key)) : null);
  view.budget = whole('budget');
  view.interactionBudget = whole('ibudget');
  const quality = h.get('quality')?.split(',');
  if (quality && finite(quality[0]) && finite(quality[1])) {
    view.interactionQuality = Math.min(Math.max(Math.round(Number(quality[0])), 1), 100);
    view.stillQuality = Math.min(Math.max(Math.round(Number(quality[1])), 1), 100);
    view.pngStills = quality[2] === 'png';
  }
  Object.assign(view, planesFromHash(h));
  Object.assign(view, regionsFromHash(h));
  Object.assign(view, timeFromHash(h));
  return view;
}

// ---------- tf.set ----------

// Opacity as sent: the overall scale, then the unit distance. The renderer's opacity is
// that of a slab `defaultUnit` thick; a point reaching alpha over `unitDistance` instead has
// alpha' = 1 - (1 - alpha)^(defaultUnit / unitDistance) over the renderer's slab (equal
// extinction), so the unit distance is exact without a protocol field.
export function sentAlpha(alpha, view, defaultUnit) {
  let a = Math.min(1, alpha * view.opacityScale);
  if (view.unitDistance > 0 && defaultUnit > 0 && a < 1) a = 1 - (1 - a) ** (defaultUnit / view.unitDistance);
  return Math.min(Math.max(a, 0), 1);
}

// A log scale applies where the whole range is above 0 (a legend and the colours say so).
export const logScale = (view) => !!view.logScale && view.range?.[0] > 0;
const kLogColorPoints = 64;

export function tfBody(view, defaultUnit) {
  const [lo, hi] = view.range;
  const at = (t) => lo + t * (hi - lo);
  // on a log scale the colour at value x is the colour points' at t = log(x / lo) / log(hi / lo),
  // sent as points evenly spaced in log10 (the renderer interpolates linearly between them)
  const colors = logScale(view)
    ? Array.from({ length: kLogColorPoints }, (_, k) => [lo * (hi / lo) ** (k / (kLogColorPoints - 1)), ...colorAt(view.colors, k / (kLogColorPoints - 1))])
    : view.colors.map(([t, r, g, b]) => [at(t), r, g, b]);
  let opacity = effectiveOpacity(view).map(([t, a]) => [at(t), sentAlpha(a, view, defaultUnit)]);
  if (view.outsideTransparent) {
    // the renderer clamps values outside the range to the end points: make the ends 0,
    // a thousandth of the range inside them
    const eps = (hi - lo) * 1e-3;
    opacity = [[lo, 0], ...opacity.map(([v, a]) => [Math.min(Math.max(v, lo + eps), hi - eps), a]), [hi, 0]];
  }
  return { attribute: view.attribute, ...(view.component && view.component !== 'magnitude' ? { component: view.component } : {}), range: [lo, hi], opacity, colors };
}
