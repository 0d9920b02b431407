// A page that says what it is doing, in headless Chromium: "Connecting…" then "Loading …" over
// the view before the first image (not a black canvas), "Refining…" on the refinement bar with
// the dataset's own tet count, each frame's own latency in the stats (a still's from the input
// it answers, not the last moving frame's), a stats box that can be hidden (and stays hidden
// after a reload), and a lost connection: the reconnect countdown counts down, and input made
// while disconnected (a drag, a wheel, a key, a colormap) is dropped, not replayed after the
// reconnect. Reconnects are held off by pointing the page's WebSocket at a closed port.
// Ordering only: no assertion on how long anything takes.
//   node --test tests/browser/status.test.mjs   (TETRA_BINARY: the tetrascope executable)
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { startViewer, settled as settledOn } from './harness.mjs';

let viewer, url, page;

// Records what #view-status says from the moment the page parses, and wraps WebSocket so a
// test can send reconnects to a closed port (window.holdReconnects).
const recordStatus = () => {
  window.statusSeen = [];
  const record = () => {
    const status = document.getElementById('view-status');
    const entry = { state: status?.hidden ? '' : (status?.dataset.state ?? 'none'), text: status?.textContent ?? '', frames: window.tetrascope?.frames ?? 0 };
    const last = window.statusSeen.at(-1);
    if (!last || last.state !== entry.state || last.text !== entry.text) window.statusSeen.push(entry);
  };
  document.addEventListener('DOMContentLoaded', () => {
    record();
    new MutationObserver(record).observe(document.getElementById('view') ?? document.body, { subtree: true, attributes: true, childList: true, characterData: true });
  });
  const Real = window.WebSocket;
  window.holdReconnects = false;
  window.sentTimes = new Map();  // message id -> when it went out
  window.WebSocket = class extends Real {
    constructor(address, protocols) {
      super(window.holdReconnects ? address.replace(/\/\/[^/]+/, '//127.0.0.1:9') : address, protocols);
    }
    send(text) {
      window.sentTimes.set(JSON.parse(text).id, performance.now());
      super.send(text);
    }
  };
};

before(async () => {
  // 5 ms frames, steps doubling: the sample refines in several steps
  viewer = await startViewer({ prefix: 'tetrascope-status-', serveArgs: ['--frame-ms', '5', '--refine-growth', '2'], viewport: { width: 900, height: 560 } });
  ({ url, page } = viewer);
  await page.addInitScript(recordStatus);
});

after(async () => {
  await viewer?.stop();
});

const settled = () => settledOn(page, 0);
// the page loaded and still (a test run on its own loads it)
async function ready() {
  if (page.url() === 'about:blank') await page.goto(url);
  await settled();
}

test('before the first image the view says it is connecting, then loading the dataset', async () => {
  await page.goto(url);
  await settled();
  const seen = await page.evaluate(() => window.statusSeen);
  const states = seen.map((s) => s.state);
  const connecting = states.indexOf('connecting'), loading = states.indexOf('loading');
  assert.ok(connecting >= 0 && /Connecting/.test(seen[connecting].text), `"Connecting…" shows first: ${JSON.stringify(seen)}`);
  assert.ok(loading > connecting && seen.some((s) => s.state === 'loading' && /Loading disk/.test(s.text)), `then "Loading disk…": ${JSON.stringify(seen)}`);
  assert.ok(seen.filter((s) => s.state !== '').every((s) => s.frames === 0), 'both before the first frame');
  assert.equal(await page.isHidden('#view-status'), true, 'gone with the image');
});

test('refinement says "Refining…" with the tets of the dataset, not of the budget', async () => {
  await ready();
  await page.evaluate(() => {
    window.bars = [];
    window.tetrascope.onFrame = (h) => h.refining && window.bars.push(document.querySelector('#refine-progress span').textContent);
  });
  await page.keyboard.press('r');
  await settled();
  const bars = await page.evaluate(() => window.bars);
  const tets = await page.evaluate(() => window.tetrascope.dataset.tets);
  assert.ok(bars.length >= 1, 'refinement steps came');
  for (const text of bars) {
    assert.match(text, /^Refining…/);
    const of = Number(text.match(/of ([\d,]+) tets/)[1].replace(/,/g, ''));
    assert.ok(of <= tets, `"${text}": at most the dataset's ${tets} tets`);
  }
});

test('each frame shows its own latency: a still\'s, refinement included, not the last moving frame\'s', async () => {
  await ready();
  await page.evaluate(() => {
    window.latencies = [];
    window.tetrascope.onFrame = (h) => {
      const line = document.getElementById('stats').textContent.split('\n')[1];
      window.latencies.push({ id: h.message_id, still: h.still, refining: h.refining, line, shown: Number(line.match(/latency (\d+) ms/)?.[1] ?? NaN), at: performance.now(), sent: window.sentTimes.get(h.message_id) });
    };
  });
  // a drag (moving frames, each answering its own message), then its refinement to a still
  const box = await page.locator('#frame').boundingBox();
  await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
  await page.mouse.down();
  await page.mouse.move(box.x + box.width / 2 + 150, box.y + box.height / 2 + 30, { steps: 12 });
  await page.mouse.up();
  await settled();
  const frames = await page.evaluate(() => window.latencies);
  const still = frames.at(-1);
  assert.ok(still.still && frames.some((f) => !f.still && !f.refining), `moving frames, then a still: ${JSON.stringify(frames)}`);
  for (const f of frames) {
    // what the page shows is its own from send to screen: never more than the test measures
    // around it (the page reads its clock a moment before the send and after the frame)
    assert.ok(f.shown <= f.at - f.sent + 20, `a frame shows ${f.line}, its own ${(f.at - f.sent).toFixed(0)} ms`);
  }
  // the still came after every frame before it that answers the same message: its latency is
  // later than theirs, not a copy of the last one
  const before = frames.slice(0, -1).filter((f) => f.id === still.id);
  assert.ok(before.length >= 1, `refinement steps before the still: ${JSON.stringify(frames)}`);
  assert.ok(still.shown >= Math.floor(before.at(-1).at - still.sent) - 1, `the still shows ${still.line}; the step before it came ${(before.at(-1).at - still.sent).toFixed(0)} ms after the input`);
  assert.ok(still.shown > Math.max(...before.map((f) => f.shown)), `the still's ${still.shown} ms against its steps' ${before.map((f) => f.shown)}`);
  assert.match(still.line, /\(input to still\)/);
});

test('the stats box can be hidden, stays hidden after a reload, and s shows it again', async () => {
  await ready();
  assert.equal(await page.isVisible('#stats'), true);
  await page.click('#stats-toggle');
  assert.equal(await page.isHidden('#stats'), true, 'the toggle hides it');
  await page.reload();
  await settled();
  assert.equal(await page.isHidden('#stats'), true, 'still hidden after a reload');
  await page.locator('#frame').focus();
  await page.keyboard.press('s');
  assert.equal(await page.isVisible('#stats'), true, 's shows it');
});

// Closes the connection with reconnects held off (sent to a closed port) until `release()`.
async function disconnect() {
  const connects = await page.evaluate(() => {
    window.holdReconnects = true;
    window.tetrascope.closeSocket();
    return window.tetrascope.connects;
  });
  return async () => {
    await page.evaluate(() => (window.holdReconnects = false));
    await page.waitForFunction((n) => window.tetrascope.connects > n, connects, { timeout: 30000 });
    await settled();
  };
}

test('while disconnected the reconnect countdown counts down', async () => {
  await ready();
  const release = await disconnect();
  // a countdown from 2 s or more (the third failed try waits 2 s), then a smaller number
  // before the next try
  const seconds = () => Number(document.getElementById('banner').textContent.match(/in (\d+) s/)?.[1] ?? NaN);
  await page.waitForFunction(`(${seconds})() >= 2`, null, { timeout: 30000 });
  const start = await page.evaluate(() => ({ text: document.getElementById('banner').textContent, closes: window.tetrascope.closes.length }));
  const first = Number(start.text.match(/in (\d+) s/)[1]);
  await page.waitForFunction(`(${seconds})() < ${first} || window.tetrascope.closes.length > ${start.closes}`, null, { timeout: 30000 });
  const later = await page.evaluate(() => ({ text: document.getElementById('banner').textContent, closes: window.tetrascope.closes.length }));
  assert.equal(later.closes, start.closes, `the countdown moved before the next try: "${start.text}" -> "${later.text}"`);
  assert.ok(Number(later.text.match(/in (\d+) s/)[1]) < first, `"${start.text}" -> "${later.text}"`);
  await release();
  assert.equal(await page.isHidden('#banner'), true, 'the banner goes with the reconnect');
});

test('input made while disconnected is dropped, not replayed after the reconnect', async () => {
  await ready();
  const before = await page.evaluate(() => ({ camera: window.tetrascope.view.camera, preset: window.tetrascope.view.preset }));
  const release = await disconnect();
  // a drag, a wheel, a key, another colormap
  const box = await page.locator('#frame').boundingBox();
  await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
  await page.mouse.down();
  await page.mouse.move(box.x + box.width / 2 + 120, box.y + box.height / 2 + 40, { steps: 6 });
  await page.mouse.up();
  await page.mouse.wheel(0, -300);
  await page.keyboard.press('x');
  const other = await page.evaluate((preset) => [...document.getElementById('colormap').options].map((o) => o.value).find((v) => v !== preset && v !== 'custom'), before.preset);
  await page.selectOption('#colormap', other);
  await release();
  const after = await page.evaluate(() => ({ camera: window.tetrascope.view.camera, preset: window.tetrascope.view.preset, sent: window.tetrascope.sent.filter((m) => m.type === 'camera.set').at(-1)?.body }));
  assert.deepEqual(after.camera, before.camera, 'the camera is the one before the connection was lost');
  for (const key of ['eye', 'target', 'up']) assert.deepEqual(after.sent[key], before.camera[key], `the camera sent after the reconnect: ${key}`);
  assert.equal(after.preset, before.preset, 'the colormap chosen while disconnected is dropped');
  assert.equal(await page.inputValue('#colormap'), before.preset, 'and the control shows the one in use');
});
