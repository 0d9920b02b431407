// The tetrascope viewer: one WebSocket session (protocol/js/codec.js), frames drawn on a
// canvas, camera and display controls, the transfer-function editor. The whole view lives in
// one object (view-state.js): the controls edit it, the URL fragment mirrors it, and it is
// sent again in full after every (re)connect, so a reconnect or a link shows the same image.
import { checkMessage, decodeFrame, encodeMessage, VERSION } from '/protocol/js/codec.js';
import { OrbitCamera } from './camera.js';
import { PRESETS, colorAt, fromHex, toHex } from './colormaps.js';
import { Jobs } from './jobs.js';
import { LinesPanel } from './lines.js';
import { TensorsPanel } from './tensors.js';
import { backgroundOf, composeStill, drawAxes, drawBox, inkOn, showLegends } from './overlays.js';
import { PlanesPanel } from './planes.js';
import { Probe } from './probe.js';
import { RegionsPanel, shownBounds } from './regions.js';
import { TimePanel } from './time.js';
import { TfEditor } from './tf-editor.js';
import { componentsOf, drawnName, effectiveOpacity, forDataset, histogramOfDrawn, logScale, rangeOfDrawn, tfBody, viewFromHash, viewToHash } from './view-state.js';
import { visibleCorners } from './visible.js';

const $ = (id) => document.getElementById(id);
const params = new URLSearchParams(location.search);
const token = params.get('token') ?? '';
// X-Tetrascope: the server refuses state-changing calls without it (or JSON) when it has no token
const authHeaders = token ? { Authorization: `Bearer ${token}`, 'X-Tetrascope': '1' } : { 'X-Tetrascope': '1' };
const kSmallScreen = window.matchMedia('(max-width: 700px)');
const kRotateStep = 1 / 12;  // arrow keys: 15° (orbit takes fractions of pi)
const kZoomStep = 1.2;
const kWheelZoomRate = 0.001;  // the distance scales by exp(rate * deltaY): about 10% a notch
const kMinZoomBox = 4;  // px: a smaller box is a click (the probe)
const kCaptureTimeoutMs = 60000;
const kDefaultBackground = [0.1, 0.1, 0.12];  // the renderer's

// What the page shows; exposed for the browser test and the console.
const state = {
  connected: false,
  connects: 0,
  frames: 0,
  stills: 0,
  refiningFrames: 0,  // refinement steps shown (frames flagged refining)
  lastFrame: null,  // {header, blob}
  lastStill: null,
  lastSentId: 0,    // a still whose header carries this id shows everything asked for
  dataset: null,    // dataset.info
  errors: [],
  picks: [],        // what the double-clicks and zoom boxes hit: {hit, position, surface}
  sent: [],         // the last messages sent: {type, body}
  received: [],     // the last text messages received: {type, id, code}
  closes: [],       // the connection's ends: {code, reason, at (ms since the page loaded)}
  view: viewFromHash(location.hash),
  closeSocket: () => socket?.close(),
  opacityPoints: () => effectiveOpacity(state.view),
  composeStill: null,
  onFrame: null,      // (header) => void, after each frame is drawn (tests)
};
window.tetrascope = state;

// What pixel (x, y) of the view shows, as the server's probe.result (the browser tests and
// the console measure the view with it).
const probeWaiters = new Map();  // probe id -> resolve
state.probePixel = (x, y) =>
  new Promise((resolve, reject) => {
    const id = send('probe', { x, y });
    if (id < 0) reject(new Error('not connected'));
    else probeWaiters.set(id, resolve);
  });

let socket = null;
let nextId = 1;
let reconnectDelay = 500;
const sentAt = new Map();  // message id -> time sent
let camera = null;
let limits;
let serverDefaults = {};
let pendingCamera = false;
let pendingTf = false;
let capture = null;        // a still at a chosen size being waited for: {id, resolve, reject}

const frameCanvas = $('frame');
const frameContext = frameCanvas.getContext('2d');
const linesPanel = new LinesPanel($('vector-panel'), frameCanvas, {
  send: (type, body) => send(type, body),
  onModes: () => onModes(),
  view: () => state.view,
  saved: () => saveViewInHash(),
  camera: () => camera?.get() ?? null,
});
const tensorsPanel = new TensorsPanel($('tensor-panel'), {
  send: (type, body) => send(type, body),
  onModes: () => onModes(),
  onLegend: () => drawLegend(),
  view: () => state.view,
  saved: () => saveViewInHash(),
});
const tfEditor = new TfEditor($('tf-editor'), onTfEdited, { onSelectColor });
const planes = new PlanesPanel($('planes'), {
  send,
  view: () => state.view,
  bounds: () => state.dataset?.bounds ?? null,
  viewDirection: () => camera && camera.get().target.map((t, i) => t - camera.get().eye[i]),
  saved: () => saveViewInHash(),
});
const regionsPanel = new RegionsPanel($('boundary-panel'), {
  send,
  view: () => state.view,
  showBoundary: () => {
    $('mode-surface').checked = true;
    onModes();
  },
  saved: () => saveViewInHash(),
});
const timePanel = new TimePanel($('time-panel'), {
  send,
  view: () => state.view,
  saved: () => saveViewInHash(),
});
state.time = timePanel;
const probe = new Probe(frameCanvas, $('probe'), { send });
state.probe = probe;
const jobs = new Jobs(authHeaders, {
  onDatasetsChanged: () => datasetList(),
  onDone: (name) => openDataset(name),
});

// ---------- connection ----------

function send(type, body = {}) {
  if (!socket || socket.readyState !== WebSocket.OPEN) return -1;
  const id = nextId++;
  const text = encodeMessage(type, id, body);
  checkMessage(text, limits);  // our own messages follow the schema too
  sentAt.set(id, performance.now());
  state.lastSentId = id;
  state.sent.push({ type, body });
  if (state.sent.length > 100) state.sent.shift();
  if (sentAt.size > 512) sentAt.delete(sentAt.keys().next().value);
  socket.send(text);
  return id;
}

function banner(text) {
  $('banner').hidden = !text;
  $('banner').textContent = text ?? '';
}

// What the view is waiting for, over the image: 'connecting', 'loading' (a dataset opened,
// its first frame not here yet), 'refining' (frames flagged refining), 'empty' (no dataset),
// or '' (nothing: the image is current).
function viewStatus(name, text = '') {
  const status = $('view-status');
  status.dataset.state = name;
  status.textContent = text;
  status.hidden = !name;
}

// The reconnect countdown: the banner says how long until the next try, second by second.
const reconnect = {
  at: 0,        // performance.now() of the next try
  timer: null,  // the banner's ticker
  reason: '',
  schedule(delay, reason) {
    this.at = performance.now() + delay;
    this.reason = reason;
    clearTimeout(this.timer);
    this.tick();
  },
  tick() {
    const left = Math.max(0, this.at - performance.now());
    if (left <= 0) {
      banner(`Connection lost${this.reason}; reconnecting…`);
      connect();
      return;
    }
    banner(`Connection lost${this.reason}; reconnecting in ${Math.ceil(left / 1000)} s. Changes made meanwhile are not kept.`);
    this.timer = setTimeout(() => this.tick(), Math.min(left, (left % 1000) || 1000));
  },
};

function connect() {
  const url = `${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/api/v1/session${token ? `?token=${encodeURIComponent(token)}` : ''}`;
  if (!state.frames) viewStatus('connecting', 'Connecting to the server…');
  socket = new WebSocket(url);
  socket.binaryType = 'arraybuffer';
  socket.onopen = () => {
    state.connected = true;
    state.connects += 1;
    reconnectDelay = 500;
    banner(null);
    if (!state.frames) viewStatus('loading', 'Loading the dataset list…');
    send('hello', { version: VERSION, ...(token ? { token } : {}) });
  };
  socket.onmessage = (event) => (typeof event.data === 'string' ? onText(event.data) : onFrame(event.data));
  socket.onclose = (event) => {
    state.connected = false;
    state.closes.push({ code: event.code, reason: event.reason, at: Math.round(performance.now()) });
    // what is done while disconnected is dropped: the view goes back to this one on reconnect
    viewAtClose ??= structuredClone(state.view);
    pointers.clear();
    pinch = null;
    capture?.reject(new Error('the connection was lost'));
    reconnect.schedule(reconnectDelay, event.reason ? ` (${event.reason})` : '');
    reconnectDelay = Math.min(reconnectDelay * 2, 10000);
  };
}
let viewAtClose = null;  // the view when the connection was lost

let openId = 0, openName = null;  // the last dataset.open sent

function onText(text) {
  const message = JSON.parse(text);
  state.received.push({ type: message.type, id: message.id, code: message.code });
  if (state.received.length > 20) state.received.shift();
  switch (message.type) {
    case 'hello.ok':
      if (viewAtClose) [state.view, viewAtClose] = [viewAtClose, null];
      limits = { ...limits, ...message.limits };
      serverDefaults = message.defaults ?? {};
      $('budget').value = state.view.budget ?? serverDefaults.budget ?? '';
      $('interaction-budget').value = state.view.interactionBudget ?? serverDefaults.interaction_budget ?? '';
      sendSize();
      // a reconnect reopens the dataset shown; onDataset then sends the whole view again
      datasetList().then((datasets) => openDataset(state.view.dataset ?? firstReady(datasets)));
      break;
    case 'dataset.info':
      onDataset(message);
      break;
    case 'probe.result':
      if (message.id === pick?.id) onPicked(message);
      else if (probeWaiters.has(message.id)) probeWaiters.get(message.id)(message);
      else probe.show(message);
      probeWaiters.delete(message.id);
      break;
    case 'error':
      state.errors.push(message);
      console.warn(`server: ${message.code}: ${message.message}`);
      $('dataset-summary').textContent = `${message.code}: ${message.message}`;
      // a link to a dataset gone, a list out of date, or a store that fails its checks
      if ((message.code === 'not_found' || message.code === 'dataset_damaged') && message.id === openId) {
        const missing = openName;
        forget(missing);
        const first = firstReady(lastDatasets);
        if (first) openDataset(first);  // each try forgets one name: this ends
      }
      // the dataset shown was deleted, or closed for every session when its store failed a check
      if (message.code === 'dataset_deleted' || (message.code === 'dataset_damaged' && message.id == null)) datasetDeleted(message.message);
      break;
    default:
      break;
  }
}

async function onFrame(buffer) {
  const { header, payload } = decodeFrame(buffer, limits);
  const blob = new Blob([payload], { type: header.codec === 'png' ? 'image/png' : 'image/jpeg' });
  if (capture && header.still && header.message_id >= capture.id) {
    capture.resolve({ header, blob, camera: cameraOf(header) });
    capture = null;
    return;
  }
  if (capture) return;  // frames at the capture's size are not for the screen
  const bitmap = await createImageBitmap(blob);
  frameContext.drawImage(bitmap, 0, 0, frameCanvas.width, frameCanvas.height);
  bitmap.close?.();
  state.frames += 1;
  state.lastFrame = { header, blob, camera: cameraOf(header) };
  drawBoxOverlay(header);
  if (header.still) {
    state.stills += 1;
    state.lastStill = state.lastFrame;
    saveViewInHash();
  }
  if (header.refining) state.refiningFrames += 1;
  if (header.message_id >= openId) viewStatus('');  // the dataset asked for is on the screen
  stats.frame(header, payload.length);
  refinement.frame(header);
  linesPanel.onFrame(header);
  timePanel.onFrame(header);
  state.onFrame?.(header);  // a hook for the browser test: called once a frame is on the screen
}

// ---------- stats overlay ----------

const stats = {
  times: [],
  latency: null,
  frame(header, bytes) {
    const now = performance.now();
    this.times.push(now);
    while (this.times.length && now - this.times[0] > 1000) this.times.shift();
    // each frame's own: from the message it answers to this frame (a still's includes its
    // refinement), never the last moving frame's
    const sent = sentAt.get(header.message_id);
    this.latency = sent === undefined ? null : now - sent;
    $('stats').textContent =
      `${this.times.length} fps   ${header.still ? 'still' : header.refining ? 'refining' : 'moving'}\n` +
      `latency ${this.latency === null ? '–' : this.latency.toFixed(0)} ms (input to ${header.still ? 'still' : 'frame'})\n` +
      `${header.tets.toLocaleString()} tets, ${header.width}x${header.height}\n` +
      `estimated error ${header.estimated_error.toPrecision(3)}\n` +
      `${(bytes / 1024).toFixed(1)} KB/frame, render ${header.render_ms.toFixed(0)} ms, encode ${header.encode_ms.toFixed(1)} ms`;
  },
};

// ---------- refinement progress ----------

// After input stops the server refines in steps (frames flagged refining) up to the still;
// the bar shows how far, in tets of the still budget, and goes away with the still or new input.
const refinement = {
  frame(header) {
    const bar = $('refine-progress');
    if (!header.refining) {
      bar.hidden = true;
      bar.dataset.state = header.still ? 'still' : 'moving';
      return;
    }
    // the still draws at most the budget, and never more tets than the dataset has
    const budget = Math.min(state.view.budget ?? serverDefaults.budget ?? header.tets, state.dataset?.tets ?? Infinity);
    bar.hidden = false;
    bar.dataset.state = 'refining';
    bar.querySelector('progress').value = Math.min(1, header.tets / budget);
    bar.querySelector('span').textContent = `Refining… ${header.tets.toLocaleString()} of ${budget.toLocaleString()} tets, est. error ${header.estimated_error.toPrecision(3)}`;
  },
};

// ---------- datasets ----------

let lastDatasets = [];
const firstReady = (datasets) => datasets.find((d) => d.state === 'ready')?.name;

// The list is asked for again after a failed request (a fetch can fail while the server is
// busy, e.g. right after a deletion it announced): 4 tries over about 2 s.
async function loadDatasets() {
  let datasets;
  for (let attempt = 0; ; ++attempt) {
    try {
      const response = await fetch('/api/v1/datasets', { headers: authHeaders });
      if (!response.ok) throw new Error(`HTTP ${response.status}`);
      ({ datasets } = await response.json());
      break;
    } catch (error) {
      if (attempt >= 3) throw new Error(`the dataset list could not be loaded: ${error.message}`);
      await new Promise((resolve) => setTimeout(resolve, 250 * 2 ** attempt));
    }
  }
  lastDatasets = datasets;
  listFailure = '';
  const select = $('dataset');
  const current = state.view.dataset ?? select.value;
  select.replaceChildren(
    ...datasets.map((d) => {
      const option = new Option(d.state === 'ready' ? `${d.name} (${(d.tets / 1e6).toFixed(2)}M tets)` : `${d.name}: ${d.state}`, d.name);
      option.disabled = d.state !== 'ready';
      return option;
    }),
  );
  if (current) select.value = current;
  return datasets;
}

// The list, or where it cannot be loaded the one last loaded, less `gone` (a dataset just
// deleted): the session still answers dataset.open, and a name deleted since is answered
// not_found, which opens the first one left.
async function datasetList(gone) {
  try {
    return await loadDatasets();
  } catch (error) {
    state.errors.push({ code: 'dataset_list', message: error.message });
    if (state.errors.length > 50) state.errors.shift();  // a list that keeps failing adds one every few seconds
    console.warn(error.message);
    listFailure = error.message;
    forget(gone);
    return lastDatasets;
  }
}
let listFailure = '';  // why the last list request failed ('' once one succeeds)
let listRetry = null;
let listRetryGeneration = 0;  // moved by every open: a retry under way opens nothing then

// A dataset known to be gone, out of the list and the menu.
function forget(name) {
  lastDatasets = lastDatasets.filter((d) => d.name !== name);
  [...$('dataset').options].find((o) => o.value === name)?.remove();
}

// The dataset shown was deleted (here or elsewhere): say so and open another.
async function datasetDeleted(text) {
  const gone = state.view.dataset;
  state.dataset = null;
  const datasets = await datasetList(gone);
  if (state.dataset) return;  // another dataset was opened meanwhile (picked, or a reconnect's)
  const next = datasets.find((d) => d.state === 'ready' && d.name !== gone)?.name;
  openDataset(next);
  if (next) datasetNotice = `${text}\nNow showing ${next}.`;  // shown with its dataset.info
  else $('dataset-summary').textContent = `${text}\n${$('dataset-summary').textContent}`;  // and why nothing opened
}
let datasetNotice = '';

async function deleteDataset() {
  const name = $('dataset').value;
  if (!name || !window.confirm(`Delete the dataset '${name}' from the server? Sessions viewing it are closed.`)) return;
  const response = await fetch(`/api/v1/datasets/${encodeURIComponent(name)}`, { method: 'DELETE', headers: authHeaders });
  const body = await response.json().catch(() => ({}));
  if (!response.ok) {
    $('dataset-summary').textContent = `Not deleted: ${body.error?.message ?? response.status}`;
    return;
  }
  if (body.upload_deleted) $('uploads-status').textContent = `Deleted ${body.upload_deleted} with ${name}.`;
  jobs.refreshUploads();
  if (name !== state.view.dataset) await loadDatasets();  // else the server's dataset_deleted follows
}

function openDataset(name) {
  clearTimeout(listRetry);
  const generation = ++listRetryGeneration;
  if (!name) {
    if (!listFailure) {
      $('dataset-summary').textContent = 'No dataset yet: add a mesh below.';
      viewStatus('empty', 'No dataset on this server yet: drop a mesh file here, or choose one under “Add a dataset”.');
      page.empty(true);
      return;
    }
    viewStatus('loading', `${listFailure}. Trying again…`);
    // no list to pick from (the server too busy to answer, a proxy in the way): say so, not
    // "no dataset", and ask again until a list comes or a dataset is opened
    $('dataset-summary').textContent = `${listFailure}. Trying again…`;
    listRetry = setTimeout(async () => {
      const datasets = await datasetList();
      if (generation === listRetryGeneration && !state.dataset) openDataset(firstReady(datasets));
    }, 3000);
    return;
  }
  $('dataset').value = name;
  page.empty(false);
  openName = name;
  openId = send('dataset.open', { name });
  if (openId >= 0) viewStatus('loading', `Loading ${name}…`);
}

function defaultUnit() {  // the renderer's unit distance: 1/100 of the box diagonal
  const b = state.dataset?.bounds;
  return b?.min && b?.max ? Math.hypot(...b.max.map((v, i) => v - b.min[i])) / 100 : 0;
}

function onDataset(info) {
  state.dataset = info;
  let view = state.view;
  if (view.dataset !== info.name) view = forDataset(view, info.name);  // another dataset: its own defaults
  if (!view.attribute) view = { ...view, attribute: info.attributes[0]?.name ?? null };  // a link without one: the first, its range kept
  else if (!info.attributes.some((a) => a.name === view.attribute)) view = { ...view, attribute: info.attributes[0]?.name ?? null, range: null, isovalues: [] };
  const a = info.attributes.find((x) => x.name === view.attribute);
  if (!componentsOf(a).includes(view.component)) view = { ...view, component: 'magnitude' };  // a scalar, or a component it lacks
  if (!view.range && a) view.range = rangeOfDrawn(a, view.component);
  state.view = view;
  camera = view.camera ? new OrbitCamera(view.camera) : homeCamera();
  $('parallel').checked = camera.orthographic;
  $('attribute').replaceChildren(...info.attributes.map((x) => new Option(`${x.name}${x.components > 1 ? ' (vector)' : ''}`, x.name)));
  $('iso-color-by').replaceChildren(new Option('value (the colour map)', ''), ...info.attributes.map((x) => new Option(`${x.name}${x.components > 1 ? ' (magnitude)' : ''}`, x.name)));
  if (view.isoColorBy && !info.attributes.some((a) => a.name === view.isoColorBy)) view.isoColorBy = null;
  $('dataset-summary').textContent = `${info.tets.toLocaleString()} tets, ${info.vertices.toLocaleString()} vertices, ${info.levels} levels\nfrom ${info.source}`;
  if (datasetNotice) $('dataset-summary').textContent += `\n${datasetNotice}`;
  datasetNotice = '';
  linesPanel.setDataset(info);
  tensorsPanel.setDataset(info);
  regionsPanel.setDataset(info);
  timePanel.setDataset(info);
  showView();
  planes.show();
  sendAll();
}

function attributeInfo() {
  return state.dataset?.attributes.find((a) => a.name === state.view.attribute);
}

// ---------- the view -> the controls ----------

function showView() {
  const v = state.view;
  if (v.attribute) $('attribute').value = v.attribute;
  showComponents();
  showColormap();
  if (v.range) {
    $('range-min').value = +v.range[0].toPrecision(6);
    $('range-max').value = +v.range[1].toPrecision(6);
  }
  $('outside-transparent').checked = v.outsideTransparent;
  showLogScale();
  $('opacity-scale').value = Math.round(v.opacityScale * 100);
  $('opacity-scale-text').textContent = `${Math.round(v.opacityScale * 100)}%`;
  $('unit-distance').value = v.unitDistance ?? '';
  $('unit-distance').placeholder = defaultUnit() ? `${+defaultUnit().toPrecision(3)} (default)` : '';
  for (const m of ['dvr', 'iso', 'surface']) $(`mode-${m}`).checked = v[m];
  $('wireframe').checked = v.wireframe;
  $('background').value = toHex(v.background ?? kDefaultBackground);
  $('box').checked = v.box;
  $('iso-opacity').value = Math.round(v.isoOpacity * 100);
  $('iso-opacity').disabled = v.dvr;  // the renderer blends isosurfaces only without the volume
  $('iso-color-by').value = v.isoColorBy ?? '';
  showIsovalues();
  if (v.budget) $('budget').value = v.budget;
  if (v.interactionBudget) $('interaction-budget').value = v.interactionBudget;
  $('interaction-quality').value = v.interactionQuality;
  $('still-quality').value = v.stillQuality;
  $('png-stills').checked = v.pngStills;
  const a = attributeInfo();
  if (a) tfEditor.setHistogram(rangeOfDrawn(a, v.component), histogramOfDrawn(a, v.component));
  showTf();
}

// The component selector (ParaView's Magnitude, X, Y, Z): shown for a vector attribute only.
function showComponents() {
  const choices = componentsOf(attributeInfo());
  $('component-row').hidden = choices.length === 0;
  $('component').replaceChildren(...choices.map((c) => new Option(c === 'magnitude' ? 'Magnitude' : c.toUpperCase(), c)));
  if (choices.length) $('component').value = state.view.component;
}

// The log scale's box: checked as the view asks, disabled while the range reaches 0 or below.
function showLogScale() {
  const v = state.view, box = $('log-scale');
  box.checked = v.logScale;
  box.disabled = !(v.range?.[0] > 0);
  box.parentElement.title = box.disabled ? 'a log scale needs a range above 0 (set min above 0)' : 'colours over log10 of the range';
}

function showColormap() {
  const select = $('colormap'), v = state.view;
  const names = Object.keys(PRESETS);
  select.replaceChildren(...names.map((n) => new Option(n, n)), ...(v.customColors ? [new Option(`${v.preset} (edited)`, 'custom')] : []));
  select.value = v.customColors ? 'custom' : v.preset;
}

function showTf() {
  const v = state.view;
  if (!v.range) return;
  tfEditor.set(v.range, effectiveOpacity(v), v.colors);
  drawLegend();
}

function midRange() {
  const [lo, hi] = state.view.range ?? [0, 1];
  return (lo + hi) / 2;
}

function showIsovalues() {
  const v = state.view;
  const values = v.isovalues.length ? v.isovalues : [midRange()];
  $('isovalues').value = values.map((x) => +x.toPrecision(5)).join(', ');
  const [lo, hi] = v.range ?? [0, 1];
  $('isovalue').value = Math.round(((values[0] - lo) / (hi - lo)) * 1000);
}

// One legend per coloured thing: the attribute's (volume, isosurfaces, boundary, slices,
// points: one colour map over one range), and the stream lines' (the field's magnitude over
// the dataset's range of it, through the same colours as the renderer samples them).
function legends() {
  const v = state.view, out = [];
  const slices = v.slices.length > 0;
  const isoBy = v.iso && v.isoColorBy ? state.dataset?.attributes.find((a) => a.name === v.isoColorBy) : null;
  const colouring = [v.dvr && 'volume', v.iso && !isoBy && 'isosurface', v.surface && 'boundary', slices && 'slice', v.lines?.points && 'points'].filter(Boolean);
  if (colouring.length && v.range && v.attribute) {
    const drawn = drawnName(attributeInfo() ?? { name: v.attribute, components: 1 }, v.component);
    const name = state.dataset ? `${state.dataset.name} — ${drawn}` : drawn;
    out.push({ key: 'attribute', title: v.legendTitles?.attribute || name, caption: `${colouring.join(', ')}${logScale(v) ? ', log scale' : ''}`, colors: v.colors, range: v.range, log: logScale(v) });
  }
  // the lines and isosurfaces coloured by another attribute take the renderer's colour table:
  // the colours sent, evenly over the colour range, spread over that attribute's range
  const table = () => {
    const sent = tfBody(v, defaultUnit()).colors, [lo, hi] = v.range;
    return Array.from({ length: 64 }, (_, k) => [k / 63, ...colorAt(sent.map(([x, ...rgb]) => [(x - lo) / (hi - lo), ...rgb]), k / 63)]);
  };
  const rangeOf = (a) => (a.range[1] > a.range[0] ? a.range : [a.range[0], a.range[0] + 1]);
  if (isoBy && v.range) out.push({ key: 'iso', title: v.legendTitles?.iso || (isoBy.components > 1 ? `|${isoBy.name}|` : isoBy.name), caption: 'isosurface', colors: table(), range: rangeOf(isoBy), log: false });
  const field = v.lines?.on && state.dataset?.attributes.find((a) => (v.lines.field ? a.name === v.lines.field : a.components === 3));
  if (field && v.range) out.push({ key: 'lines', title: v.legendTitles?.lines || `|${field.name}|`, caption: 'stream lines', colors: table(), range: rangeOf(field), log: false });
  const tensors = v.range ? tensorsPanel.legend(state.dataset, table()) : null;
  if (tensors) out.push({ ...tensors, title: v.legendTitles?.tensors || tensors.title });
  return out;
}

// Drawn again when what they show changes (and not under a title being edited).
let legendsShown = '';
function drawLegend() {
  const shown = legends(), key = JSON.stringify(shown);
  if (key === legendsShown || $('legend').contains(document.activeElement)) return;
  legendsShown = key;
  showLegends($('legend'), shown, (which, text) => {
    state.view.legendTitles = { ...state.view.legendTitles, [which]: text || null };
    drawLegend();
    saveViewInHash();
  });
}

// ---------- the view -> messages ----------

function sendAll() {
  if (!state.dataset) return;
  sendTf();
  sendMode();
  sendIso();
  linesPanel.sendAll();
  tensorsPanel.sendAll();
  sendLod();
  sendQuality();
  planes.sendAll();
  regionsPanel.send();
  timePanel.send();
  sendCamera(false);  // last: the still that follows shows everything
  saveViewInHash();
}

function sendSize(width, height) {
  if (width === undefined) {
    const rect = frameCanvas.getBoundingClientRect();
    const ratio = Math.min(window.devicePixelRatio || 1, 2);
    const side = limits?.max_image_side ?? 4096;
    width = Math.max(16, Math.min(side, Math.round(rect.width * ratio)));
    height = Math.max(16, Math.min(side, Math.round(rect.height * ratio)));
    frameCanvas.width = width;
    frameCanvas.height = height;
  }
  return send('view.resize', { width, height });
}

function sendCamera(interacting = true) {
  if (!camera) return;
  const id = send('camera.set', { ...camera.get(), interacting });
  state.view.camera = camera.get();
  if (id >= 0) camerasSent.push([id, camera.get()]);
  if (camerasSent.length > 64) camerasSent.shift();
  drawAxes($('axes'), camera.basis());
  if (!interacting) saveViewInHash();
}

// The cameras sent, by message id: a frame is drawn with the last one its message_id covers
// (the box overlay follows the image, not the input running ahead of it).
const camerasSent = [];  // [id, camera]
const cameraOf = (header) => camerasSent.findLast(([id]) => id <= header.message_id)?.[1] ?? state.view.camera;

// The dataset's box over the frame, in an ink chosen from the frame's background (the
// renderer's own box lines are near-black: they vanish on its dark background).
function drawBoxOverlay(header) {
  const overlay = $('box-overlay'), g = overlay.getContext('2d');
  if (overlay.width !== frameCanvas.width || overlay.height !== frameCanvas.height) [overlay.width, overlay.height] = [frameCanvas.width, frameCanvas.height];
  g.clearRect(0, 0, overlay.width, overlay.height);
  const camera = header && cameraOf(header);
  if (!state.view.box || !state.dataset?.bounds || !camera) return;
  drawBox(g, camera, state.dataset.bounds, overlay.width, overlay.height, inkOn(backgroundOf(frameContext, frameCanvas.width, frameCanvas.height)));
}

function queueCamera() {  // at most one camera.set per animation frame
  if (pendingCamera) return;
  pendingCamera = true;
  requestAnimationFrame(() => {
    pendingCamera = false;
    sendCamera(true);
  });
}

function sendTf() {
  const v = state.view;
  if (!v.range || !v.attribute) return;
  send('tf.set', tfBody(v, defaultUnit()));
}

function queueTf() {  // at most one tf.set per animation frame
  if (pendingTf) return;
  pendingTf = true;
  requestAnimationFrame(() => {
    pendingTf = false;
    sendTf();
    saveViewInHash();
  });
}

// `extra`: fields sent this once (the default background again after a custom one: a session
// that never had one is sent none)
function sendMode(extra = {}) {
  const v = state.view;
  // none of them: 'slice', the slice planes alone (an image of the box, or nothing, without any)
  const mode = [...['dvr', 'iso', 'surface'].filter((m) => v[m]), ...linesPanel.modes(), ...tensorsPanel.modes()].join('+') || 'slice';
  send('mode.set', { mode, wireframe: v.wireframe, box: false, ...(v.background ? { background: v.background } : {}), ...extra });  // the box: drawBoxOverlay
  drawBoxOverlay(state.lastFrame?.header);
}

function sendIso() {
  const v = state.view;
  send('iso.set', { values: v.isovalues.length ? v.isovalues : [midRange()], opacity: v.isoOpacity, color_by: v.isoColorBy ?? '' });
}

function sendLod() {
  const v = state.view, body = {};
  if (v.budget) body.budget = v.budget;
  if (v.interactionBudget) body.interaction_budget = v.interactionBudget;
  if (v.maxError !== undefined && v.maxError !== null) body.max_error = v.maxError;
  if (Object.keys(body).length) send('lod.set', body);
}

function sendQuality() {
  const v = state.view;
  send('quality.set', { interaction: v.interactionQuality, still: v.stillQuality, still_codec: v.pngStills ? 'png' : 'jpeg' });
}

function saveViewInHash() {
  if (!state.dataset) return;
  drawLegend();  // the view changed: the legends follow (drawn again only when they differ)
  history.replaceState(null, '', `${location.pathname}${location.search}#${viewToHash(state.view)}`);
}

// ---------- controls -> the view ----------

function onTfEdited() {
  const v = state.view;
  if (JSON.stringify(effectiveOpacity(v)) !== JSON.stringify(tfEditor.opacityPoints)) v.opacity = tfEditor.opacityPoints.map((p) => [...p]);
  const colorsChanged = JSON.stringify(v.colors) !== JSON.stringify(tfEditor.colorPoints);
  if (colorsChanged) {
    v.colors = tfEditor.colorPoints.map((p) => [...p]);
    if (!v.customColors) {
      v.customColors = true;
      showColormap();
    }
    drawLegend();
    const rgb = tfEditor.selectedColor();
    if (rgb) $('tf-color').value = toHex(rgb);
  }
  queueTf();
}

function onSelectColor(rgb, openPicker = false) {
  $('tf-color').disabled = !rgb;
  if (!rgb) return;
  $('tf-color').value = toHex(rgb);
  if (openPicker) $('tf-color').click();
}

function onAttribute() {
  const a = state.dataset?.attributes.find((x) => x.name === $('attribute').value);
  if (!a) return;
  const component = componentsOf(a).includes(state.view.component) ? state.view.component : 'magnitude';
  Object.assign(state.view, { attribute: a.name, component, range: rangeOfDrawn(a, component), isovalues: [] });
  state.view.legendTitles = { ...state.view.legendTitles, attribute: null };  // the new attribute's name
  showView();
  sendTf();
  sendIso();
  saveViewInHash();
}

// Another component of the vector: its own range over the dataset, the isovalues again mid-range.
function onComponent() {
  const a = attributeInfo(), component = $('component').value;
  if (!a || !componentsOf(a).includes(component)) return;
  Object.assign(state.view, { component, range: rangeOfDrawn(a, component), isovalues: [] });
  state.view.legendTitles = { ...state.view.legendTitles, attribute: null };  // the component's name
  showView();
  sendTf();
  sendIso();
  saveViewInHash();
}

function onRange() {
  const lo = parseFloat($('range-min').value), hi = parseFloat($('range-max').value);
  if (!(Number.isFinite(lo) && Number.isFinite(hi) && hi > lo)) return;
  state.view.range = [lo, hi];
  showLogScale();
  showTf();
  showIsovalues();
  queueTf();
}

function onModes() {
  const v = state.view;
  for (const m of ['dvr', 'iso', 'surface']) v[m] = $(`mode-${m}`).checked;  // any combination, none included
  v.wireframe = $('wireframe').checked;
  v.box = $('box').checked;
  $('iso-opacity').disabled = v.dvr;
  sendMode();
  saveViewInHash();
}

function onIsoSlider() {
  const [lo, hi] = state.view.range ?? [0, 1];
  const values = state.view.isovalues.length ? [...state.view.isovalues] : [midRange()];
  values[0] = lo + (parseInt($('isovalue').value, 10) / 1000) * (hi - lo);
  state.view.isovalues = values;
  $('isovalues').value = values.map((x) => +x.toPrecision(5)).join(', ');
  sendIso();
  saveViewInHash();
}

function onIsoText() {
  const values = $('isovalues').value.split(/[,\s]+/).filter(Boolean).map(Number).filter(Number.isFinite).slice(0, limits?.max_isovalues ?? 16);
  state.view.isovalues = values;
  showIsovalues();
  sendIso();
  saveViewInHash();
}

function onPreset() {
  const name = $('colormap').value;
  if (!PRESETS[name]) return;
  Object.assign(state.view, { preset: name, colors: PRESETS[name].map((p) => [...p]), customColors: false });
  showColormap();
  showTf();
  queueTf();
}

// ---------- camera: presets and keys ----------

// ParaView's view directions (the camera looks along them) and up vectors
const kViews = {
  '+x': [[1, 0, 0], [0, 0, 1]], '-x': [[-1, 0, 0], [0, 0, 1]],
  '+y': [[0, 1, 0], [0, 0, 1]], '-y': [[0, -1, 0], [0, 0, 1]],
  '+z': [[0, 0, 1], [0, 1, 0]], '-z': [[0, 0, -1], [0, 1, 0]],
};

// The dataset's opening view; on a portrait view further back, so that the width fits as the
// height does (the field of view is vertical).
function homeCamera() {
  const home = new OrbitCamera(state.dataset.camera);
  const aspect = frameCanvas.width / frameCanvas.height;
  if (aspect > 0 && aspect < 1) home.zoom(1 / aspect);
  return home;
}

// A preset looks along its direction and frames what is visible from there (fitVisible).
function viewPreset(name) {
  if (!state.dataset || !camera) return;
  const home = homeCamera().get();
  if (name === 'reset') {
    const parallel = camera.orthographic;
    camera = homeCamera();
    camera.orthographic = parallel;
  } else {
    const distance = Math.hypot(...home.eye.map((e, i) => e - home.target[i]));
    const [direction, up] = name === 'iso' ? [[-1, -1, -1], home.up] : kViews[name];
    camera.look(direction, up, home.target, distance);
    frameVisible();
  }
  sendCamera(false);
}

// The camera keeps its direction and frames the part of the dataset's box the clip planes
// keep: the whole domain, or the region a clip cut out; the boundary alone with regions
// hidden: the box of the regions shown (regions.js).
function frameVisible() {
  const corners = visibleCorners(shownBounds(state.dataset, state.view), state.view.clips);
  if (corners.length) camera.fit(corners, frameCanvas.width / frameCanvas.height);
}

function fitVisible() {
  if (!state.dataset || !camera) return;
  frameVisible();
  sendCamera(false);
}

// ---------- rotation centre (double-click) and zoom to box ----------

// A double-click asks the server's probe what the pixel shows (slice, isosurface or boundary);
// the point hit becomes the rotation centre (OrbitCamera.centreOn). The probe popups of its
// two clicks are dropped.
let pick = null;  // the probe asked for: {id, then(message)}
function pickAt(clientX, clientY, then) {
  if (!camera || !state.connected) return;
  probe.cancel();
  const rect = frameCanvas.getBoundingClientRect();
  const x = ((clientX - rect.left) / rect.width) * frameCanvas.width, y = ((clientY - rect.top) / rect.height) * frameCanvas.height;
  const id = send('probe', { x: Math.max(0, x), y: Math.max(0, y) });
  if (id >= 0) pick = { id, then };
}

function onPicked(message) {
  const { then } = pick;
  pick = null;
  state.picks.push({ hit: message.hit, position: message.position ?? null, surface: message.surface ?? null });
  if (state.picks.length > 20) state.picks.shift();
  if (camera) then(message);
}

const pointText = (p) => `(${p.map((v) => +v.toPrecision(4)).join(', ')})`;

function centreAt(e) {
  pickAt(e.clientX, e.clientY, (message) => {
    if (!message.hit) return flashNote('Nothing under the cursor to turn about');
    camera.centreOn(message.position);
    sendCamera(false);
    flashNote(`Rotation centre: the ${message.surface} at ${pointText(message.position)}`);
  });
}

// Zoom to box (ParaView's): the box's middle goes to the middle of the view on the plane
// through the rotation centre facing the camera, and the box fills the view. The rotation
// centre moves with it. (Not a probe at the box's middle: in the volume the nearest surface
// there is often the far field in front, and a box drawn over a hole of a slice would land on
// it.)
function zoomToBox(a, b) {
  const rect = frameCanvas.getBoundingClientRect();
  const w = Math.abs(a.x - b.x), h = Math.abs(a.y - b.y);
  if (!camera || (w < kMinZoomBox && h < kMinZoomBox)) return;
  camera.pan(...cursorOffset((a.x + b.x) / 2, (a.y + b.y) / 2));
  camera.zoom(Math.max(w / rect.width, h / rect.height));
  sendCamera(false);
}

// The box being drawn (Ctrl+drag, or a drag after the Zoom to box button or the b key).
const zoomBox = {
  armed: false,  // the next drag draws a box
  start: null,
  arm(on = !this.armed) {
    this.armed = on;
    $('zoom-box-button').setAttribute('aria-pressed', String(on));
    frameCanvas.classList.toggle('boxing', on);
  },
  begin(e) {
    this.start = { x: e.clientX, y: e.clientY };
    this.draw(e);
  },
  draw(e) {
    const rect = frameCanvas.getBoundingClientRect(), box = $('zoom-box');
    Object.assign(box.style, {
      left: `${Math.min(this.start.x, e.clientX) - rect.left}px`, top: `${Math.min(this.start.y, e.clientY) - rect.top}px`,
      width: `${Math.abs(e.clientX - this.start.x)}px`, height: `${Math.abs(e.clientY - this.start.y)}px`,
    });
    box.hidden = false;
  },
  end(e) {
    const start = this.start;
    this.start = null;
    $('zoom-box').hidden = true;
    this.arm(false);
    if (e) zoomToBox(start, { x: e.clientX, y: e.clientY });
  },
};

// A short note over the view (rotation centre set, nothing hit), gone after a few seconds.
function flashNote(text) {
  const note = $('view-note');
  note.textContent = text;
  note.hidden = false;
  clearTimeout(flashNote.timer);
  flashNote.timer = setTimeout(() => (note.hidden = true), 3000);
}

function onKey(e) {
  if (e.ctrlKey || e.metaKey || e.altKey) return;
  const tag = e.target?.tagName;
  if ((tag === 'INPUT' && !['checkbox', 'range', 'button'].includes(e.target.type)) || tag === 'SELECT' || tag === 'TEXTAREA') return;
  const key = e.key;
  if (key === '?') return toggleHelp();
  if (key === 'Escape') {
    toggleHelp(false);
    if (zoomBox.armed) zoomBox.arm(false);
    if (kSmallScreen.matches) setPanel(false);
    return;
  }
  const lower = key.toLowerCase();
  if (lower === 's') {
    showStats(!statsShown());
    e.preventDefault();
    return;
  }
  if (!camera || !state.connected) return;  // not moved while disconnected: the reconnect would undo it
  if (lower === 'r') viewPreset('reset');
  else if (lower === 'x' || lower === 'y' || lower === 'z') viewPreset(`${e.shiftKey ? '-' : '+'}${lower}`);
  else if (lower === 'i') viewPreset('iso');
  else if (lower === 'f') fitVisible();
  else if (lower === 'b') zoomBox.arm();
  else if (lower === 'p') setParallel(!camera.orthographic);
  else if (key === 'ArrowLeft' || key === 'ArrowRight' || key === 'ArrowUp' || key === 'ArrowDown') {
    if (tag === 'INPUT') return;  // a focused slider takes its arrows
    const step = kRotateStep;
    camera.orbit(key === 'ArrowLeft' ? -step : key === 'ArrowRight' ? step : 0, key === 'ArrowUp' ? -step : key === 'ArrowDown' ? step : 0);
    sendCamera(false);
  } else if (key === '+' || key === '=') {
    camera.zoom(1 / kZoomStep);
    sendCamera(false);
  } else if (key === '-' || key === '_') {
    camera.zoom(kZoomStep);
    sendCamera(false);
  } else return;
  e.preventDefault();
}

function setParallel(on) {
  if (!camera) return;
  camera.orthographic = on;
  $('parallel').checked = on;
  sendCamera(false);
}

// The stats box: shown, or hidden by its toggle or s (kept in localStorage); hidden at first on
// a small screen, where it covers the top of the view.
const kStatsKey = 'tetrascope.stats';
const statsShown = () => !$('stats').hidden;
function showStats(on) {
  $('stats').hidden = !on;
  $('stats-toggle').setAttribute('aria-pressed', String(on));
  try {
    localStorage.setItem(kStatsKey, on ? 'shown' : 'hidden');
  } catch {
    // no storage (a private window): the choice lasts for this page
  }
}
function initialStats() {
  let saved = null;
  try {
    saved = localStorage.getItem(kStatsKey);
  } catch {
    // no storage
  }
  const on = saved ? saved === 'shown' : !kSmallScreen.matches;
  $('stats').hidden = !on;
  $('stats-toggle').setAttribute('aria-pressed', String(on));
}

function toggleHelp(show = $('help').hidden) {
  $('help').hidden = !show;
}

// ---------- saving ----------

// A still at width x height (the view's size when not given), as a blob; the screen keeps
// its own size.
async function stillAt(width, height) {
  if (!width || (width === frameCanvas.width && height === frameCanvas.height)) {
    if (state.lastStill && state.lastStill.header.message_id === state.lastSentId) return state.lastStill;
  }
  const result = new Promise((resolve, reject) => {
    capture = { id: Infinity, resolve, reject };
    setTimeout(() => reject(new Error('no still came')), kCaptureTimeoutMs);
  });
  const w = width ?? frameCanvas.width, h = height ?? frameCanvas.height;
  capture.id = sendSize(w, h);
  sendCamera(false);
  try {
    return await result;
  } finally {
    capture = null;
    sendSize();
    sendCamera(false);
  }
}

function chosenSize() {
  const choice = $('save-size').value;
  let w, h;
  if (choice === 'view') return [undefined, undefined];
  if (choice === 'custom') [w, h] = [parseInt($('save-width').value, 10), parseInt($('save-height').value, 10)];
  else [w, h] = choice.split('x').map(Number);
  const side = limits?.max_image_side ?? 4096;
  const s = Math.min(1, side / Math.max(w, h));  // the server's limit, keeping the aspect
  return [Math.max(16, Math.round(w * s)), Math.max(16, Math.round(h * s))];
}

async function saveImage() {
  if (!state.dataset) return;
  const status = $('save-status');
  const [w, h] = chosenSize();
  status.textContent = w ? `Rendering ${w}×${h}...` : 'Saving...';
  $('save-image').disabled = true;  // one capture at a time
  try {
    const still = await stillAt(w, h);
    const blob = await composeStill(await createImageBitmap(still.blob), legendOf(still));
    const a = document.createElement('a');
    a.href = URL.createObjectURL(blob);
    a.download = `${state.dataset.name}-${state.view.attribute}.png`;
    a.click();
    setTimeout(() => URL.revokeObjectURL(a.href), 1000);
    status.textContent = `Saved ${still.header.width}×${still.header.height} PNG with the legend.`;
  } catch (e) {
    status.textContent = `Not saved: ${e.message}`;
  } finally {
    $('save-image').disabled = false;
  }
}
// What composeStill draws over `still` ({header, blob, camera}): the legend, and the box when
// it is on, seen with the camera the still was drawn with.
function legendOf(still) {
  const v = state.view;
  const box = v.box && state.dataset.bounds ? { camera: still.camera ?? v.camera, bounds: state.dataset.bounds } : null;
  return { legends: legends(), box };
}
state.composeStill = async () => composeStill(await createImageBitmap(state.lastStill.blob), legendOf(state.lastStill));

async function copyViewLink() {
  saveViewInHash();
  const feedback = $('copy-feedback');
  try {
    await navigator.clipboard.writeText(location.href);
    feedback.textContent = 'Link copied ✓';
  } catch {
    // no clipboard (an http page, or no permission): the old way, from a selected field
    const field = Object.assign(document.createElement('textarea'), { value: location.href });
    document.body.append(field);
    field.select();
    const copied = document.execCommand?.('copy');
    field.remove();
    feedback.textContent = copied ? 'Link copied ✓' : 'Copy the link from the address bar (the page has no clipboard)';
  }
  feedback.classList.add('flash');
  clearTimeout(copyViewLink.timer);
  copyViewLink.timer = setTimeout(() => {
    feedback.textContent = '';
    feedback.classList.remove('flash');
  }, 4000);
}

// ---------- pointer, wheel, touch ----------

const pointers = new Map();
let pinch = null;

// The cursor's offset from the view's centre, in view heights (x right, y down): what
// OrbitCamera.zoomAt takes.
function cursorOffset(clientX, clientY) {
  const rect = frameCanvas.getBoundingClientRect();
  return [(clientX - rect.left - rect.width / 2) / rect.height, (clientY - rect.top - rect.height / 2) / rect.height];
}

frameCanvas.addEventListener('pointerdown', (e) => {
  frameCanvas.setPointerCapture(e.pointerId);
  frameCanvas.focus();
  if (e.button === 0 && (e.ctrlKey || zoomBox.armed) && pointers.size === 0 && camera && state.connected) {
    zoomBox.begin(e);
    return;
  }
  pointers.set(e.pointerId, { x: e.clientX, y: e.clientY, button: e.button, shift: e.shiftKey });
  if (pointers.size === 2) {
    const [a, b] = [...pointers.values()];
    pinch = { distance: Math.hypot(a.x - b.x, a.y - b.y), x: (a.x + b.x) / 2, y: (a.y + b.y) / 2 };
  }
});
frameCanvas.addEventListener('pointermove', (e) => {
  if (zoomBox.start) return zoomBox.draw(e);
  const p = pointers.get(e.pointerId);
  if (!p || !camera || !state.connected) return;
  const height = frameCanvas.getBoundingClientRect().height;
  if (pointers.size === 2 && pinch) {
    p.x = e.clientX;
    p.y = e.clientY;
    const [a, b] = [...pointers.values()];
    const distance = Math.hypot(a.x - b.x, a.y - b.y), x = (a.x + b.x) / 2, y = (a.y + b.y) / 2;
    camera.pan(-(x - pinch.x) / height, -(y - pinch.y) / height);
    if (distance > 0) camera.zoomAt(pinch.distance / distance, ...cursorOffset(x, y));
    pinch = { distance, x, y };
  } else {
    const dx = (e.clientX - p.x) / height, dy = (e.clientY - p.y) / height;
    p.x = e.clientX;
    p.y = e.clientY;
    if (p.button === 2 || p.button === 1 || p.shift) camera.pan(-dx, -dy);  // the image follows the cursor
    else camera.orbit(dx, dy);
  }
  queueCamera();
});
const release = (e) => {
  if (zoomBox.start) zoomBox.end(e.type === 'pointerup' ? e : null);
  pointers.delete(e.pointerId);
  if (pointers.size < 2) pinch = null;
};
frameCanvas.addEventListener('pointerup', release);
frameCanvas.addEventListener('pointercancel', release);
frameCanvas.addEventListener('contextmenu', (e) => e.preventDefault());
// A double-tap sets the rotation centre as a double-click does (a browser may send no dblclick
// for touches): two taps within kDoubleTapMs and kDoubleTapPx.
const kDoubleTapMs = 400, kDoubleTapPx = 24;
let lastTap = null, tapCentredAt = -Infinity;
frameCanvas.addEventListener('pointerup', (e) => {
  if (e.pointerType !== 'touch' || pointers.size > 0) return;
  const now = performance.now();
  if (lastTap && now - lastTap.at < kDoubleTapMs && Math.hypot(e.clientX - lastTap.x, e.clientY - lastTap.y) < kDoubleTapPx) {
    lastTap = null;
    tapCentredAt = now;
    centreAt(e);
  } else lastTap = { at: now, x: e.clientX, y: e.clientY };
});
frameCanvas.addEventListener('dblclick', (e) => {
  if (performance.now() - tapCentredAt > kDoubleTapMs) centreAt(e);  // not the same double-tap twice
});
frameCanvas.addEventListener(
  'wheel',
  (e) => {
    e.preventDefault();
    if (!camera || !state.connected) return;
    const [sx, sy] = cursorOffset(e.clientX, e.clientY);
    camera.zoomAt(Math.exp(e.deltaY * kWheelZoomRate), sx, sy);
    queueCamera();
  },
  { passive: false },
);

// ---------- the page: an empty server, dropped files, collapsible sections ----------

const page = {
  // On a server with no dataset the form to add one comes first (and the drawer opens on a
  // small screen); it goes back to its place once a dataset opens.
  empty(on) {
    const wasEmpty = document.body.classList.contains('empty-server');
    document.body.classList.toggle('empty-server', on);
    if (on && !wasEmpty) {
      collapse($('add-dataset'), false);
      if (kSmallScreen.matches) setPanel(true);
    }
  },
  // A file dropped onto the view is uploaded and preprocessed as if chosen in the form.
  dragDepth: 0,
  onDrag(e) {
    if (![...(e.dataTransfer?.types ?? [])].includes('Files')) return;
    e.preventDefault();
    if (e.type === 'dragenter') this.dragDepth += 1;
    if (e.type === 'dragleave') this.dragDepth = Math.max(0, this.dragDepth - 1);
    $('drop-target').hidden = this.dragDepth === 0;
  },
  onDrop(e) {
    const files = e.dataTransfer?.files;
    if (!files?.length) return;
    e.preventDefault();
    this.dragDepth = 0;
    $('drop-target').hidden = true;
    $('upload-file').files = files;
    $('job-name').value = '';
    collapse($('add-dataset'), false);
    jobs.uploadAndPreprocess().catch((error) => ($('job-status').textContent = String(error)));
  },
};

// Each panel section folds under its heading; which are folded is kept in localStorage.
const kFoldedKey = 'tetrascope.folded';
const sectionName = (section) => section.id || section.querySelector('h2')?.textContent.trim() || '';
function foldedSections() {
  try {
    return new Set(JSON.parse(localStorage.getItem(kFoldedKey) ?? '[]'));
  } catch {
    return new Set();  // no storage, or a value not ours
  }
}
function collapse(section, folded) {
  section.classList.toggle('folded', folded);
  section.querySelector('h2')?.setAttribute('aria-expanded', String(!folded));
  const names = foldedSections();
  if (folded) names.add(sectionName(section));
  else names.delete(sectionName(section));
  try {
    localStorage.setItem(kFoldedKey, JSON.stringify([...names]));
  } catch {
    // no storage (a private window): folded for this page only
  }
}
function initialSections() {
  const folded = foldedSections();
  for (const section of $('panel').querySelectorAll(':scope > section')) {
    const heading = section.querySelector('h2');
    if (!heading) continue;
    heading.tabIndex = 0;
    heading.setAttribute('role', 'button');
    heading.setAttribute('aria-expanded', String(!folded.has(sectionName(section))));
    section.classList.toggle('folded', folded.has(sectionName(section)));
    const toggle = () => collapse(section, !section.classList.contains('folded'));
    heading.addEventListener('click', toggle);
    heading.addEventListener('keydown', (e) => {
      if (e.key !== 'Enter' && e.key !== ' ') return;
      e.preventDefault();
      toggle();
    });
  }
}

// ---------- wiring ----------

const number = (id) => parseFloat($(id).value);
$('dataset').addEventListener('change', () => openDataset($('dataset').value));
$('dataset-delete').addEventListener('click', deleteDataset);
$('attribute').addEventListener('change', onAttribute);
$('component').addEventListener('change', onComponent);
$('colormap').addEventListener('change', onPreset);
$('range-min').addEventListener('change', onRange);
$('range-max').addEventListener('change', onRange);
$('range-reset').addEventListener('click', () => {
  const a = attributeInfo();
  if (!a) return;
  [$('range-min').value, $('range-max').value] = rangeOfDrawn(a, state.view.component);
  onRange();
});
$('tf-reset').addEventListener('click', () => {
  const v = state.view;
  Object.assign(v, { opacity: null, colors: PRESETS[v.preset].map((p) => [...p]), customColors: false, opacityScale: 1 });
  showView();
  queueTf();
});
$('tf-invert').addEventListener('click', () => {  // ParaView's Invert: the colour points mirrored
  const v = state.view;
  Object.assign(v, { colors: v.colors.map(([t, ...rgb]) => [+(1 - t).toPrecision(6), ...rgb]).reverse(), customColors: true });
  showColormap();
  showTf();
  queueTf();
});
$('log-scale').addEventListener('change', () => {
  state.view.logScale = $('log-scale').checked;
  showTf();
  queueTf();
});
$('tf-color').addEventListener('input', () => tfEditor.recolorSelected(fromHex($('tf-color').value)));
$('outside-transparent').addEventListener('change', () => {
  state.view.outsideTransparent = $('outside-transparent').checked;
  queueTf();
});
$('opacity-scale').addEventListener('input', () => {
  state.view.opacityScale = number('opacity-scale') / 100;
  $('opacity-scale-text').textContent = `${$('opacity-scale').value}%`;
  queueTf();
});
$('unit-distance').addEventListener('change', () => {
  const u = number('unit-distance');
  state.view.unitDistance = u > 0 ? u : null;
  queueTf();
});
for (const id of ['mode-dvr', 'mode-iso', 'mode-surface', 'wireframe', 'box']) $(id).addEventListener('change', onModes);
$('isovalue').addEventListener('input', onIsoSlider);
$('isovalues').addEventListener('change', onIsoText);
$('iso-color-by').addEventListener('change', () => {
  state.view.isoColorBy = $('iso-color-by').value || null;
  sendIso();
  saveViewInHash();
});
$('iso-opacity').addEventListener('input', () => {
  state.view.isoOpacity = number('iso-opacity') / 100;
  sendIso();
  saveViewInHash();
});
for (const [id, key] of [['budget', 'budget'], ['interaction-budget', 'interactionBudget']]) {
  $(id).addEventListener('change', () => {
    const value = parseInt($(id).value, 10);
    state.view[key] = value > 0 ? value : null;
    sendLod();
    saveViewInHash();
  });
}
$('max-error').addEventListener('change', () => {
  const value = parseFloat($('max-error').value);
  state.view.maxError = value > 0 ? value : 0;  // 0: refine up to the budget
  sendLod();
});
for (const id of ['interaction-quality', 'still-quality', 'png-stills']) {
  $(id).addEventListener('change', () => {
    Object.assign(state.view, { interactionQuality: parseInt($('interaction-quality').value, 10), stillQuality: parseInt($('still-quality').value, 10), pngStills: $('png-stills').checked });
    sendQuality();
    saveViewInHash();
  });
}
for (const button of document.querySelectorAll('[data-view]')) button.addEventListener('click', () => viewPreset(button.dataset.view));
$('reset-camera').addEventListener('click', () => viewPreset('reset'));
$('fit-visible').addEventListener('click', fitVisible);
$('zoom-box-button').addEventListener('click', () => zoomBox.arm());
$('parallel').addEventListener('change', () => setParallel($('parallel').checked));
for (const [id, event] of [['background', 'change'], ['background-reset', 'click']]) {
  $(id).addEventListener(event, () => {
    state.view.background = id === 'background' ? fromHex($('background').value) : null;
    $('background').value = toHex(state.view.background ?? kDefaultBackground);
    sendMode(state.view.background ? {} : { background: kDefaultBackground });
    saveViewInHash();
  });
}
$('copy-view').addEventListener('click', copyViewLink);
$('save-size').addEventListener('change', () => ($('save-custom').hidden = $('save-size').value !== 'custom'));
$('save-image').addEventListener('click', saveImage);
$('upload-submit').addEventListener('click', () => jobs.uploadAndPreprocess().catch((e) => ($('job-status').textContent = String(e))));
$('help-button').addEventListener('click', () => toggleHelp());
$('stats-toggle').addEventListener('click', () => showStats(!statsShown()));
initialStats();
initialSections();
for (const type of ['dragenter', 'dragover', 'dragleave']) $('view').addEventListener(type, (e) => page.onDrag(e));
$('view').addEventListener('drop', (e) => page.onDrop(e));
window.addEventListener('keydown', onKey);

// the panel: beside the view on wide screens, a drawer over it on small ones
function setPanel(open) {
  document.body.classList.toggle('panel-open', open);
  $('panel-toggle').setAttribute('aria-expanded', String(open));
}
$('panel-toggle').addEventListener('click', () => setPanel(!document.body.classList.contains('panel-open')));
kSmallScreen.addEventListener('change', () => setPanel(false));
// on a small screen a tap on the view beside the open drawer closes it (the tap moves nothing)
$('view').addEventListener('pointerdown', (e) => {
  if (!kSmallScreen.matches || !document.body.classList.contains('panel-open') || e.target === $('panel-toggle')) return;
  setPanel(false);
  e.stopPropagation();
  e.preventDefault();
}, { capture: true });

let resizeTimer = null;
window.addEventListener('resize', () => {
  clearTimeout(resizeTimer);
  resizeTimer = setTimeout(() => {
    sendSize();
    sendCamera(false);
  }, 150);
});

connect();
jobs.start();
