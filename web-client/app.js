// The tetrascope viewer: one WebSocket session (protocol/js/codec.js), frames drawn on a
// canvas, camera and display controls, the transfer-function editor, uploads and jobs.
import { checkMessage, decodeFrame, encodeMessage, VERSION } from '/protocol/js/codec.js';
import { OrbitCamera } from './camera.js';
import { TfEditor } from './tf-editor.js';

const $ = (id) => document.getElementById(id);
const params = new URLSearchParams(location.search);
const token = params.get('token') ?? '';
// X-Tetrascope: the server refuses state-changing calls without it (or JSON) when it has no token
const authHeaders = token ? { Authorization: `Bearer ${token}`, 'X-Tetrascope': '1' } : { 'X-Tetrascope': '1' };

// What the page shows; exposed for the browser test and the console.
const state = {
  connected: false,
  frames: 0,
  stills: 0,
  lastFrame: null,  // {header, blob}
  lastStill: null,
  lastSentId: 0,    // a still whose header carries this id shows everything asked for
  dataset: null,    // dataset.info
  colormaps: {},
  errors: [],
};
window.tetrascope = state;

let socket = null;
let nextId = 1;
let reconnectDelay = 500;
const sentAt = new Map();  // message id -> time sent
let camera = null;
let limits;
let pendingCamera = false;
let pendingTf = false;

const frameCanvas = $('frame');
const frameContext = frameCanvas.getContext('2d');
const tfEditor = new TfEditor($('tf-editor'), () => queueTf());

// ---------- connection ----------

function send(type, body = {}) {
  if (!socket || socket.readyState !== WebSocket.OPEN) return -1;
  const id = nextId++;
  const text = encodeMessage(type, id, body);
  checkMessage(text, limits);  // our own messages follow the schema too
  sentAt.set(id, performance.now());
  state.lastSentId = id;
  if (sentAt.size > 512) sentAt.delete(sentAt.keys().next().value);
  socket.send(text);
  return id;
}

function banner(text) {
  $('banner').hidden = !text;
  $('banner').textContent = text ?? '';
}

function connect() {
  const url = `${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/api/v1/session${token ? `?token=${encodeURIComponent(token)}` : ''}`;
  socket = new WebSocket(url);
  socket.binaryType = 'arraybuffer';
  socket.onopen = () => {
    state.connected = true;
    reconnectDelay = 500;
    banner(null);
    send('hello', { version: VERSION, ...(token ? { token } : {}) });
  };
  socket.onmessage = (event) => (typeof event.data === 'string' ? onText(event.data) : onFrame(event.data));
  socket.onclose = (event) => {
    state.connected = false;
    const seconds = (reconnectDelay / 1000).toFixed(1);
    banner(`Connection lost${event.reason ? ` (${event.reason})` : ''}; reconnecting in ${seconds} s`);
    setTimeout(connect, reconnectDelay);
    reconnectDelay = Math.min(reconnectDelay * 2, 10000);
  };
}

function onText(text) {
  const message = JSON.parse(text);
  switch (message.type) {
    case 'hello.ok':
      limits = { ...limits, ...message.limits };
      state.colormaps = message.colormaps ?? {};
      $('budget').value = message.defaults.budget;
      $('interaction-budget').value = message.defaults.interaction_budget;
      sendView();
      loadDatasets().then(() => openDataset(viewFromHash().dataset ?? $('dataset').value));
      break;
    case 'dataset.info':
      onDataset(message);
      break;
    case 'error':
      state.errors.push(message);
      console.warn(`server: ${message.code}: ${message.message}`);
      $('dataset-summary').textContent = `${message.code}: ${message.message}`;
      break;
    default:
      break;
  }
}

async function onFrame(buffer) {
  const { header, payload } = decodeFrame(buffer, limits);
  const blob = new Blob([payload], { type: header.codec === 'png' ? 'image/png' : 'image/jpeg' });
  const bitmap = await createImageBitmap(blob);
  frameContext.drawImage(bitmap, 0, 0, frameCanvas.width, frameCanvas.height);
  bitmap.close?.();
  state.frames += 1;
  state.lastFrame = { header, blob };
  if (header.still) {
    state.stills += 1;
    state.lastStill = { header, blob };
    saveViewInHash();
  }
  stats.frame(header, payload.length);
}

// ---------- stats overlay ----------

const stats = {
  times: [],
  latency: 0,
  frame(header, bytes) {
    const now = performance.now();
    this.times.push(now);
    while (this.times.length && now - this.times[0] > 1000) this.times.shift();
    const sent = sentAt.get(header.message_id);
    if (sent !== undefined && !header.still) this.latency = now - sent;
    $('stats').textContent =
      `${this.times.length} fps   ${header.still ? 'still' : 'moving'}\n` +
      `latency ${this.latency.toFixed(0)} ms (input to frame)\n` +
      `${header.tets.toLocaleString()} tets, ${header.width}x${header.height}\n` +
      `${(bytes / 1024).toFixed(1)} KB/frame, render ${header.render_ms.toFixed(0)} ms, encode ${header.encode_ms.toFixed(1)} ms`;
  },
};

// ---------- datasets ----------

async function loadDatasets() {
  const response = await fetch('/api/v1/datasets', { headers: authHeaders });
  const { datasets } = await response.json();
  const select = $('dataset');
  const current = select.value;
  select.replaceChildren(
    ...datasets.map((d) => {
      const option = new Option(d.state === 'ready' ? `${d.name} (${(d.tets / 1e6).toFixed(2)}M tets)` : `${d.name}: ${d.state}`, d.name);
      option.disabled = d.state !== 'ready';
      return option;
    }),
  );
  if (current) select.value = current;
  if (!select.value) {
    const ready = datasets.find((d) => d.state === 'ready');
    if (ready) select.value = ready.name;
  }
  return datasets;
}

function openDataset(name) {
  if (!name) {
    $('dataset-summary').textContent = 'No dataset yet: upload a mesh below.';
    return;
  }
  $('dataset').value = name;
  send('dataset.open', { name });
}

function onDataset(info) {
  state.dataset = info;
  const view = viewFromHash();
  camera = new OrbitCamera(view.dataset === info.name && view.eye ? view : info.camera);
  $('attribute').replaceChildren(...info.attributes.map((a) => new Option(`${a.name}${a.components > 1 ? ' (magnitude)' : ''}`, a.name)));
  if (view.dataset === info.name && view.attribute) $('attribute').value = view.attribute;
  $('dataset-summary').textContent =
    `${info.tets.toLocaleString()} tets, ${info.vertices.toLocaleString()} vertices, ${info.levels} levels\nfrom ${info.source}`;
  onAttribute();
  if (view.dataset === info.name && view.eye) sendCamera(false);
}

function attributeInfo() {
  return state.dataset?.attributes.find((a) => a.name === $('attribute').value);
}

function onAttribute() {
  const a = attributeInfo();
  if (!a) return;
  $('range-min').value = a.range[0];
  $('range-max').value = a.range[1];
  tfEditor.setData(a.range, a.histogram, state.colormaps[$('colormap').value]);
  updateIsoText();
  queueTf();
  sendIso();
}

// ---------- controls -> messages ----------

function sendView() {
  const rect = frameCanvas.getBoundingClientRect();
  const ratio = Math.min(window.devicePixelRatio || 1, 2);
  const side = limits?.max_image_side ?? 4096;
  const width = Math.max(16, Math.min(side, Math.round(rect.width * ratio)));
  const height = Math.max(16, Math.min(side, Math.round(rect.height * ratio)));
  frameCanvas.width = width;
  frameCanvas.height = height;
  send('view.resize', { width, height });
}

function sendCamera(interacting = true) {
  if (!camera) return;
  send('camera.set', { ...camera.get(), interacting });
}

function queueCamera() {  // at most one camera.set per animation frame
  if (pendingCamera) return;
  pendingCamera = true;
  requestAnimationFrame(() => {
    pendingCamera = false;
    sendCamera(true);
  });
}

function currentRange() {
  const lo = parseFloat($('range-min').value), hi = parseFloat($('range-max').value);
  return Number.isFinite(lo) && Number.isFinite(hi) && hi > lo ? [lo, hi] : attributeInfo()?.range;
}

function queueTf() {
  if (pendingTf) return;
  pendingTf = true;
  requestAnimationFrame(() => {
    pendingTf = false;
    const range = currentRange();
    if (!range || !state.dataset) return;
    tfEditor.range = range;
    send('tf.set', { attribute: $('attribute').value, colormap: $('colormap').value, range, opacity: tfEditor.valuePoints() });
    drawLegend(range);
  });
}

function sendMode() {
  const parts = [];
  if ($('mode-dvr').checked) parts.push('dvr');
  if ($('mode-iso').checked) parts.push('iso');
  if ($('mode-surface').checked) parts.push('surface');
  if (!parts.length) {
    $('mode-dvr').checked = true;
    parts.push('dvr');
  }
  send('mode.set', { mode: parts.join('+'), wireframe: $('wireframe').checked, box: $('box').checked });
  // the renderer blends isosurfaces only without the volume; with it they are opaque
  $('iso-opacity').disabled = $('mode-dvr').checked;
}

function isovalue() {
  const range = currentRange() ?? [0, 1];
  return range[0] + (parseInt($('isovalue').value, 10) / 1000) * (range[1] - range[0]);
}

function updateIsoText() {
  $('isovalue-text').textContent = isovalue().toPrecision(4);
}

function sendIso() {
  updateIsoText();
  send('iso.set', { values: [isovalue()], opacity: parseInt($('iso-opacity').value, 10) / 100 });
}

function sendLod() {
  const budget = parseInt($('budget').value, 10), interaction = parseInt($('interaction-budget').value, 10);
  const body = {};
  if (budget > 0) body.budget = budget;
  if (interaction > 0) body.interaction_budget = interaction;
  if (Object.keys(body).length) send('lod.set', body);
}

function sendQuality() {
  send('quality.set', {
    interaction: parseInt($('interaction-quality').value, 10),
    still: parseInt($('still-quality').value, 10),
    still_codec: $('png-stills').checked ? 'png' : 'jpeg',
  });
}

function drawLegend(range) {
  const colors = state.colormaps[$('colormap').value];
  const bar = $('legend-bar'), g = bar.getContext('2d');
  if (colors) {
    for (let x = 0; x < bar.width; ++x) {
      const rgb = colors[Math.min(colors.length - 1, Math.floor((x / bar.width) * colors.length))];
      g.fillStyle = `rgb(${rgb.map((v) => Math.round(v * 255)).join(',')})`;
      g.fillRect(x, 0, 1, bar.height);
    }
  }
  $('legend-text').replaceChildren(
    ...[range[0].toPrecision(3), $('attribute').value, range[1].toPrecision(3)].map((t) => Object.assign(document.createElement('span'), { textContent: t })),
  );
  tfEditor.setColors(colors);
}

// ---------- saved views in the URL ----------

function viewFromHash() {
  const h = new URLSearchParams(location.hash.slice(1));
  const vector = (key) => h.get(key)?.split(',').map(Number);
  return { dataset: h.get('dataset'), attribute: h.get('attribute'), eye: vector('eye'), target: vector('target'), up: vector('up'), fov: Number(h.get('fov')) || 30 };
}

function saveViewInHash() {
  if (!camera || !state.dataset) return;
  const c = camera.get();
  const f = (v) => v.map((x) => +x.toPrecision(6)).join(',');
  const h = new URLSearchParams({ dataset: state.dataset.name, attribute: $('attribute').value, eye: f(c.eye), target: f(c.target), up: f(c.up), fov: c.fov });
  history.replaceState(null, '', `${location.pathname}${location.search}#${h}`);
}

// ---------- pointer, wheel, touch ----------

const pointers = new Map();
let pinch = null;

frameCanvas.addEventListener('pointerdown', (e) => {
  frameCanvas.setPointerCapture(e.pointerId);
  pointers.set(e.pointerId, { x: e.clientX, y: e.clientY, button: e.button, shift: e.shiftKey });
  if (pointers.size === 2) {
    const [a, b] = [...pointers.values()];
    pinch = { distance: Math.hypot(a.x - b.x, a.y - b.y), x: (a.x + b.x) / 2, y: (a.y + b.y) / 2 };
  }
});
frameCanvas.addEventListener('pointermove', (e) => {
  const p = pointers.get(e.pointerId);
  if (!p || !camera) return;
  const height = frameCanvas.getBoundingClientRect().height;
  if (pointers.size === 2 && pinch) {
    p.x = e.clientX;
    p.y = e.clientY;
    const [a, b] = [...pointers.values()];
    const distance = Math.hypot(a.x - b.x, a.y - b.y), x = (a.x + b.x) / 2, y = (a.y + b.y) / 2;
    if (distance > 0) camera.zoom(pinch.distance / distance);
    camera.pan((x - pinch.x) / height, (y - pinch.y) / height);
    pinch = { distance, x, y };
  } else {
    const dx = (e.clientX - p.x) / height, dy = (e.clientY - p.y) / height;
    p.x = e.clientX;
    p.y = e.clientY;
    if (p.button === 2 || p.button === 1 || p.shift) camera.pan(-dx, -dy);
    else camera.orbit(dx, dy);
  }
  queueCamera();
});
const release = (e) => {
  pointers.delete(e.pointerId);
  if (pointers.size < 2) pinch = null;
};
frameCanvas.addEventListener('pointerup', release);
frameCanvas.addEventListener('pointercancel', release);
frameCanvas.addEventListener('contextmenu', (e) => e.preventDefault());
frameCanvas.addEventListener(
  'wheel',
  (e) => {
    e.preventDefault();
    if (!camera) return;
    camera.zoom(Math.exp(e.deltaY * 0.001));
    queueCamera();
  },
  { passive: false },
);

// ---------- uploads and jobs ----------

async function uploadAndPreprocess() {
  const file = $('upload-file').files[0];
  const name = $('job-name').value.trim() || file?.name.replace(/\.[^.]*$/, '').replace(/[^A-Za-z0-9._-]/g, '_');
  const status = $('job-status');
  if (!file) {
    status.textContent = 'Choose a mesh file first (.vtk, .vtu, .msh, .node/.ele, .off).';
    return;
  }
  const safeFile = file.name.replace(/[^A-Za-z0-9._-]/g, '_').replace(/^\.+/, '');
  $('job-progress').value = 0;
  status.textContent = `Uploading ${file.name} (${(file.size / 1048576).toFixed(1)} MB)...`;
  const upload = await fetch(`/api/v1/uploads?name=${encodeURIComponent(safeFile)}`, { method: 'POST', headers: authHeaders, body: file });
  const uploaded = await upload.json();
  if (!upload.ok) {
    status.textContent = `Upload refused: ${uploaded.error.message}`;
    return;
  }
  const submit = await fetch('/api/v1/jobs', {
    method: 'POST',
    headers: { ...authHeaders, 'Content-Type': 'application/json' },
    body: JSON.stringify({ source: uploaded.path, name, options: {} }),
  });
  const job = await submit.json();
  if (!submit.ok) {
    status.textContent = `Job refused: ${job.error.message}`;
    return;
  }
  followJob(job.id);
}

async function followJob(id) {
  const status = $('job-status');
  for (;;) {
    const response = await fetch(`/api/v1/jobs/${encodeURIComponent(id)}`, { headers: authHeaders });
    const job = await response.json();
    $('job-progress').value = job.percent;
    const eta = job.eta_s != null && job.state === 'running' ? `, ${Math.ceil(job.eta_s)} s left` : '';
    status.textContent = `${job.name}: ${job.state}${job.stage ? ` (${job.stage})` : ''} ${job.percent.toFixed(0)}%${eta}${job.error ? `\n${job.error}` : ''}`;
    if (job.state === 'done') {
      await loadDatasets();
      openDataset(job.dataset);
      return;
    }
    if (job.state === 'failed' || job.state === 'cancelled') return;
    await new Promise((resolve) => setTimeout(resolve, 500));
  }
}

// ---------- wiring ----------

$('dataset').addEventListener('change', () => openDataset($('dataset').value));
$('attribute').addEventListener('change', onAttribute);
$('colormap').addEventListener('change', queueTf);
$('range-min').addEventListener('change', queueTf);
$('range-max').addEventListener('change', queueTf);
$('tf-reset').addEventListener('click', () => tfEditor.reset());
for (const id of ['mode-dvr', 'mode-iso', 'mode-surface', 'wireframe', 'box']) $(id).addEventListener('change', sendMode);
$('isovalue').addEventListener('input', sendIso);
$('iso-opacity').addEventListener('input', sendIso);
$('budget').addEventListener('change', sendLod);
$('interaction-budget').addEventListener('change', sendLod);
for (const id of ['interaction-quality', 'still-quality', 'png-stills']) $(id).addEventListener('change', sendQuality);
$('reset-camera').addEventListener('click', () => {
  if (!state.dataset) return;
  camera = new OrbitCamera(state.dataset.camera);
  sendCamera(false);
});
$('copy-view').addEventListener('click', () => {
  saveViewInHash();
  navigator.clipboard?.writeText(location.href);
});
$('save-image').addEventListener('click', () => {
  const still = state.lastStill ?? state.lastFrame;
  if (!still) return;
  const a = document.createElement('a');
  a.href = URL.createObjectURL(still.blob);
  a.download = `${state.dataset?.name ?? 'tetrascope'}.${still.header.codec === 'png' ? 'png' : 'jpg'}`;
  a.click();
  setTimeout(() => URL.revokeObjectURL(a.href), 1000);
});
$('upload-submit').addEventListener('click', () => uploadAndPreprocess().catch((e) => ($('job-status').textContent = String(e))));
let resizeTimer = null;
window.addEventListener('resize', () => {
  clearTimeout(resizeTimer);
  resizeTimer = setTimeout(sendView, 150);
});

connect();
