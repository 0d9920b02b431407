// Clip and slice planes in the web client, in headless Chromium (as viewer.test.mjs): adding
// a clip plane and dragging it along its normal changes the image, a slice shows, lit or
// flat, the planes go into the URL and come back from a link, the messages sent pass the
// codec, and a click reports every point attribute.
//   node --test tests/browser/planes.test.mjs   (TETRA_BINARY: the tetrascope executable)
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { startViewer, frameImage as imageOf, settled as settledOn, lastSent as lastSentOn, clientErrors } from './harness.mjs';

let viewer, url, page, browser;

before(async () => {
  viewer = await startViewer({ prefix: 'tetrascope-planes-' });
  ({ url, page, browser } = viewer);
});

after(async () => {
  await viewer?.stop();
});

const frameImage = () => imageOf(page);
const settled = () => settledOn(page);

const lastSent = (type) => lastSentOn(page, type);
const errors = () => clientErrors(page);

test('adding a clip plane and dragging it along its normal changes the image', async () => {
  await page.goto(url);
  await settled();
  const unclipped = await frameImage();
  await page.click('[data-add=clip]');
  await settled();
  const clip = await lastSent('clip.set');
  assert.equal(clip.planes.length, 1);
  assert.deepEqual(clip.planes[0].normal, [1, 0, 0]);
  const clipped = await frameImage();
  assert.notEqual(clipped, unclipped, 'the clip at the centre changed the image');
  // drag the plane's slider thumb to the left: the plane moves along -x
  const slider = page.locator('.plane-row[data-kind=clips] .plane-offset');
  const box = await slider.boundingBox();
  const y = box.y + box.height / 2;
  await page.mouse.move(box.x + box.width / 2, y);
  await page.mouse.down();
  for (let i = 1; i <= 10; ++i) await page.mouse.move(box.x + box.width / 2 - i * (box.width / 160), y);  // a sixteenth: the mesh stays partly kept
  await page.mouse.up();
  await settled();
  const dragged = await lastSent('clip.set');
  assert.ok(dragged.planes[0].offset < clip.planes[0].offset, `the plane moved along -x: ${clip.planes[0].offset} -> ${dragged.planes[0].offset}`);
  assert.notEqual(await frameImage(), clipped, 'the image changed with the drag');
  assert.match(page.url(), /clip=1:0:0:/, 'the plane is in the URL');
  assert.deepEqual(await errors(), []);
});

test('a slice with edges facing the view shows, and a normal from a preset', async () => {
  const before = await frameImage();
  await page.click('[data-add=slice]');
  await page.check('#slice-edges');
  await page.selectOption('.plane-row[data-kind=slices] .plane-normal', 'view');
  await settled();
  const slice = await lastSent('slice.set');
  assert.equal(slice.edges, true);
  const camera = await page.evaluate(() => window.tetrascope.view.camera);
  const d = camera.target.map((t, i) => t - camera.eye[i]);
  const l = Math.hypot(...d);
  slice.planes[0].normal.forEach((n, i) => assert.ok(Math.abs(n - d[i] / l) < 1e-6, `${slice.planes[0].normal} along ${d}`));
  assert.notEqual(await frameImage(), before, 'the slice shows');
  assert.match(page.url(), /slice=/);
  assert.match(page.url(), /sedges=1/);
  // lit -> flat: the slice's shading goes, the image changes, the URL says so
  const lit = await frameImage();
  assert.equal(slice.lit, true);
  await page.uncheck('#slice-lit');
  await settled();
  assert.equal((await lastSent('slice.set')).lit, false);
  assert.notEqual(await frameImage(), lit, 'the flat slice differs from the lit one');
  assert.match(page.url(), /sflat=1/);
  // a preset normal for the clip
  await page.selectOption('.plane-row[data-kind=clips] .plane-normal', '+y');
  await settled();
  assert.deepEqual((await lastSent('clip.set')).planes[0].normal, [0, 1, 0]);
  assert.deepEqual(await errors(), []);
});

test('a link brings the planes back, and removing them restores the image', async () => {
  const link = page.url();
  const shown = await frameImage();
  const other = await browser.newPage({ viewport: { width: 900, height: 700 } });
  await other.goto(link);
  await other.waitForFunction(() => window.tetrascope.sent.some((m) => m.type === 'clip.set') && window.tetrascope.sent.some((m) => m.type === 'slice.set'), null, { timeout: 60000 });
  const planes = await other.evaluate(() => ({
    clips: window.tetrascope.view.clips.length,
    slices: window.tetrascope.view.slices.length,
    rows: document.querySelectorAll('.plane-row').length,
    lit: document.getElementById('slice-lit').checked,
    sentLit: window.tetrascope.sent.filter((m) => m.type === 'slice.set').at(-1).body.lit,
  }));
  assert.deepEqual(planes, { clips: 1, slices: 1, rows: 2, lit: false, sentLit: false });
  await other.close();
  await page.click('.plane-row[data-kind=slices] .plane-remove');
  await page.click('.plane-row[data-kind=clips] .plane-remove');
  await settled();
  assert.deepEqual(await lastSent('clip.set'), { planes: [] });
  assert.notEqual(await frameImage(), shown);
  assert.doesNotMatch(page.url(), /clip=/);
});

test('a click on the image reports the field under the cursor', async () => {
  await page.click('[data-add=slice]');
  await settled();
  const box = await page.locator('#frame').boundingBox();
  await page.mouse.click(box.x + box.width / 2, box.y + box.height / 2);
  await page.waitForFunction(() => window.tetrascope.probe.last, null, { timeout: 60000 });
  const result = await page.evaluate(() => window.tetrascope.probe.last);
  assert.equal(result.hit, true, JSON.stringify(result));
  assert.ok(['slice', 'boundary'].includes(result.surface), result.surface);
  const range = await page.evaluate((name) => window.tetrascope.dataset.attributes.find((a) => a.name === name)?.range ?? null, result.attribute);
  assert.ok(Number.isFinite(result.value));
  if (range) assert.ok(result.value >= range[0] - 1e-3 * Math.abs(range[0]) && result.value <= range[1] + 1e-3 * Math.abs(range[1]), `${result.value} in ${range}`);
  // every point attribute of the dataset at that point, vectors as components and magnitude
  const attributes = await page.evaluate(() => window.tetrascope.dataset.attributes.map((a) => ({ name: a.name, components: a.components ?? null })));
  for (const a of attributes) {
    const v = result.values?.[a.name];
    assert.ok(v !== undefined, `${a.name} in ${JSON.stringify(result.values)}`);
    if (Array.isArray(v)) {
      assert.equal(v.length, 3);
      assert.ok(Math.abs(result.magnitudes[a.name] - Math.hypot(...v)) <= 1e-9 * Math.max(1, result.magnitudes[a.name]));
    } else {
      assert.ok(Number.isFinite(v));
    }
  }
  if (!Array.isArray(result.values[result.attribute])) assert.ok(Math.abs(result.values[result.attribute] - result.value) <= 1e-3 * Math.max(1, Math.abs(result.value)));
  const text = await page.textContent('#probe');
  for (const a of attributes) assert.ok(text.includes(`${a.name} =`), `${a.name} in the readout: ${text}`);
  // the sky: nothing
  await page.mouse.click(box.x + 3, box.y + 3);
  await page.waitForFunction(() => window.tetrascope.probe.last && !window.tetrascope.probe.last.hit, null, { timeout: 60000 });
  assert.deepEqual(await errors(), []);
});
