// Stream lines in the web client, in headless Chromium (as viewer.test.mjs): dashes move
// along the flow with no input and stop when paused, a rake drawn in the image seeds new
// lines (and a shift-drag box selects), the whole line state is in the URL, comes back from a
// link and is sent again after a reconnect, and every message sent passes the codec.
//   node --test tests/browser/lines.test.mjs   (TETRA_BINARY: the tetrascope executable)
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { startViewer, frameImage as imageOf, settled as settledOn, lastSent as lastSentOn, clientErrors } from './harness.mjs';

let viewer, url, page, browser;

before(async () => {
  viewer = await startViewer({ prefix: 'tetrascope-lines-' });
  ({ url, page, browser } = viewer);
});

after(async () => {
  await viewer?.stop();
});

const frameImage = () => imageOf(page);
const settled = () => settledOn(page);

const lastSent = (type) => lastSentOn(page, type);
const errors = () => clientErrors(page);

// digests of the next `n` frames shown
const nextFrames = (n) =>
  page.evaluate(
    (count) =>
      new Promise((resolve) => {
        const out = [];
        window.tetrascope.onFrame = async () => {
          const url = document.getElementById('frame').toDataURL('image/png');
          const digest = await crypto.subtle.digest('SHA-256', new TextEncoder().encode(url));
          out.push([...new Uint8Array(digest)].map((b) => b.toString(16).padStart(2, '0')).join(''));
          if (out.length === count) {
            window.tetrascope.onFrame = null;
            resolve(out);
          }
        };
      }),
    n,
  );

test('with dashes the frames move on with no input; paused, they stop', async () => {
  await page.goto(url);
  await settled();
  await page.check('#lines-on');
  await settled();
  assert.ok(await page.isHidden('#lines-animate-label'), 'no animation toggle with arrows');
  await page.selectOption('#lines-flow', 'dashes');
  assert.ok(await page.isVisible('#lines-animate-label'));
  const frames = await nextFrames(4);
  assert.ok(new Set(frames).size >= 3, `successive frames differ: ${frames.map((f) => f.slice(0, 8))}`);
  const steps = (await page.evaluate(() => window.tetrascope.sent)).filter((m) => m.type === 'lines.set' && m.body.dash_phase !== undefined);
  assert.ok(steps.length >= 3, 'the phase is sent');
  assert.deepEqual(Object.keys(steps.at(-1).body), ['dash_phase'], 'an animation step carries only the phase');
  await page.uncheck('#lines-animate');
  await settled();
  const shown = await page.evaluate(() => window.tetrascope.frames);
  const still = await frameImage();
  await page.waitForTimeout(1500);
  assert.equal(await page.evaluate(() => window.tetrascope.frames), shown, 'paused: no more frames');
  assert.equal(await frameImage(), still);
  assert.match(page.url(), /lflow=dashes/);
  assert.match(page.url(), /lpause=1/);
  assert.deepEqual(await errors(), []);
});

test('a rake drawn in the image seeds lines; a shift-drag box selects', async () => {
  await page.selectOption('#lines-flow', 'arrows');
  await settled();
  const before = await frameImage();
  await page.check('#lines-draw');
  const box = await page.locator('#frame').boundingBox();
  const y = box.y + box.height * 0.5;
  await page.mouse.move(box.x + box.width * 0.3, y);
  await page.mouse.down();
  for (let i = 1; i <= 8; ++i) await page.mouse.move(box.x + box.width * (0.3 + (0.4 * i) / 8), y);
  assert.ok(await page.isVisible('#lines-overlay'), 'the rake shows while dragging');
  await page.mouse.up();
  assert.ok(await page.isHidden('#lines-overlay'));
  await settled();
  const rake = await lastSent('lines.set');
  assert.ok(Array.isArray(rake.seeds) && rake.seeds.length === 2, JSON.stringify(rake));
  assert.equal(rake.count, 100);
  // the rake lies on the plane through the target facing the camera, and spans the drag
  const camera = await page.evaluate(() => window.tetrascope.view.camera);
  const forward = camera.target.map((t, k) => t - camera.eye[k]);
  for (const end of rake.seeds) {
    const along = end.reduce((s, v, k) => s + (v - camera.target[k]) * forward[k], 0);
    assert.ok(Math.abs(along) < 1e-6 * Math.hypot(...forward) ** 2, 'on the view plane');
  }
  assert.notEqual(await frameImage(), before, 'the new lines show');
  assert.match(page.url(), /lseeds=rake:/, 'the rake is in the URL');
  assert.equal(await page.inputValue('#lines-seeds'), 'rake');
  // a shift-drag: a box around the plane selects the lines through it
  await page.keyboard.down('Shift');
  await page.mouse.move(box.x + box.width * 0.4, box.y + box.height * 0.4);
  await page.mouse.down();
  await page.mouse.move(box.x + box.width * 0.6, box.y + box.height * 0.6, { steps: 4 });
  await page.mouse.up();
  await page.keyboard.up('Shift');
  await settled();
  const selection = (await lastSent('lines.set')).select;
  assert.ok(selection?.box, JSON.stringify(selection));
  selection.box[0].forEach((lo, k) => assert.ok(lo < selection.box[1][k]));
  assert.match(page.url(), /lselect=box:/);
  await page.uncheck('#lines-draw');
  assert.deepEqual(await errors(), []);
});

test('the line state comes back from a link and after a reconnect', async () => {
  await page.fill('#lines-count', '40');
  await page.$eval('#lines-count', (e) => e.dispatchEvent(new Event('change')));
  await page.$eval('#lines-depth', (e) => {
    e.value = '30';
    e.dispatchEvent(new Event('change'));
  });
  await settled();
  const link = page.url();
  assert.match(link, /lseeds=rake:[^&]*,40/);
  assert.match(link, /ldepth=0.3/);
  assert.match(link, /mode=dvr\+lines/);
  const rake = await lastSent('lines.set');
  // a reconnect sends the field, seeds, selection and style again
  await page.evaluate(() => {
    window.tetrascope.sent.length = 0;
    window.tetrascope.closeSocket();
  });
  await page.waitForFunction(() => window.tetrascope.sent.some((m) => m.type === 'lines.set' && m.body.seeds), null, { timeout: 30000 });
  const resent = (await page.evaluate(() => window.tetrascope.sent)).find((m) => m.type === 'lines.set' && m.body.seeds).body;
  assert.deepEqual(resent.seeds, rake.seeds ?? resent.seeds);
  assert.equal(resent.count, 40);
  assert.ok(resent.select?.box, 'the selection was sent again');
  assert.equal(resent.depth_correction, 0.3);
  assert.equal(resent.field, 'Velocity');
  await settled();
  // a link in another page: the same messages
  const other = await browser.newPage({ viewport: { width: 900, height: 700 } });
  await other.goto(link);
  await other.waitForFunction(() => window.tetrascope.sent.some((m) => m.type === 'lines.set' && m.body.seeds), null, { timeout: 60000 });
  const fromLink = await other.evaluate(() => ({
    lines: window.tetrascope.sent.find((m) => m.type === 'lines.set' && m.body.seeds).body,
    mode: window.tetrascope.sent.filter((m) => m.type === 'mode.set').at(-1)?.body.mode,
    on: document.getElementById('lines-on').checked,
    seeds: document.getElementById('lines-seeds').value,
  }));
  await other.close();
  fromLink.lines.seeds.flat().forEach((v, i) => assert.ok(Math.abs(v - resent.seeds.flat()[i]) < 1e-5 * (1 + Math.abs(v)), 'the rake, to the 6 digits of the URL'));
  assert.equal(fromLink.lines.count, 40);
  fromLink.lines.select.box.flat().forEach((v, i) => assert.ok(Math.abs(v - resent.select.box.flat()[i]) < 1e-5 * (1 + Math.abs(v))));
  assert.equal(fromLink.mode, 'dvr+lines');
  assert.ok(fromLink.on);
  assert.equal(fromLink.seeds, 'rake');
  assert.deepEqual(await errors(), []);
});
