// Navigation in headless Chromium on the bundled sample: the wheel zooms towards the cursor, a
// double-click makes the point under the cursor (the server's probe) the rotation centre, a
// box drawn with ctrl+drag fills the view, "fit what is visible" (f, the Fit button) frames the
// dataset's box or the part the clip planes keep, and the view presets frame the data from
// their direction. Positions are checked by projecting world points with the camera the page
// sent, independently of the page's own camera code.
//   node --test tests/browser/navigation.test.mjs   (TETRA_BINARY: the tetrascope executable)
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { startViewer, settled as settledOn } from './harness.mjs';
import { boxCorners, framing, project } from './projection.mjs';

let viewer, url, page;

before(async () => {
  viewer = await startViewer({ prefix: 'tetrascope-navigation-', viewport: { width: 900, height: 560 } });
  ({ url, page } = viewer);
  await page.goto(url);
  await settled();
});

after(async () => {
  await viewer?.stop();
});

const settled = () => settledOn(page, 0);
const view = () => page.evaluate(() => ({ camera: window.tetrascope.view.camera, bounds: window.tetrascope.dataset.bounds, width: document.getElementById('frame').width, height: document.getElementById('frame').height }));
const distance = (c) => Math.hypot(...c.eye.map((e, i) => e - c.target[i]));

// A pixel of the canvas, off the centre by `offset` (fractions of the width, height), whose
// ray hits the data, with the point hit; the first of a few candidates that hits.
async function pointOnData(offsets) {
  const { width, height } = await view();
  for (const [fx, fy] of offsets) {
    const pixel = [width * (0.5 + fx), height * (0.5 + fy)];
    const result = await page.evaluate(([x, y]) => window.tetrascope.probePixel(x, y), pixel);
    if (result.hit) return { pixel, position: result.position };
  }
  throw new Error('no candidate pixel shows the data');
}

async function canvasPoint(pixel) {
  const box = await page.locator('#frame').boundingBox();
  const { width } = await view();
  const scale = box.width / width;
  return [box.x + pixel[0] * scale, box.y + pixel[1] * scale];
}

test('the wheel zooms towards the cursor: the point under it stays under it', async () => {
  await page.keyboard.press('r');
  await settled();
  const { pixel, position } = await pointOnData([[0.12, 0.1], [0.1, -0.1], [-0.12, 0.12], [0.06, 0.05]]);
  const before = await view();
  const [x, y] = await canvasPoint(pixel);
  await page.mouse.move(x, y);
  for (let i = 0; i < 6; ++i) await page.mouse.wheel(0, -100);
  await settled();
  const after = await view();
  assert.ok(distance(after.camera) < 0.75 * distance(before.camera), 'six notches zoom in');
  const offset = Math.hypot(pixel[0] - before.width / 2, pixel[1] - before.height / 2);
  const moved = project(after.camera, after.width, after.height, position);
  const drift = Math.hypot(moved[0] - pixel[0], moved[1] - pixel[1]);
  // about the centre the point would move out by (1/0.55 - 1) of its offset (~80%); the plane
  // through the rotation centre stays exactly, a surface point off that plane drifts a little
  assert.ok(drift < 0.25 * offset, `the point under the cursor (${offset.toFixed(0)} px from the centre) moved ${drift.toFixed(1)} px`);
});

test('a double-click makes the point under the cursor the rotation centre', async () => {
  await page.keyboard.press('r');
  await settled();
  const { pixel, position } = await pointOnData([[0.1, 0.08], [-0.1, 0.1], [0.05, -0.08]]);
  const picks = await page.evaluate(() => window.tetrascope.picks.length);
  const [x, y] = await canvasPoint(pixel);
  await page.mouse.dblclick(x, y);
  await page.waitForFunction((n) => window.tetrascope.picks.length > n, picks);
  await settled();
  const pick = await page.evaluate(() => window.tetrascope.picks.at(-1));
  assert.equal(pick.hit, true);
  const { bounds } = await view();
  const size = Math.hypot(...bounds.max.map((v, i) => v - bounds.min[i]));
  // within a pixel's worth: the mouse lands on whole CSS pixels
  for (let k = 0; k < 3; ++k) assert.ok(Math.abs(pick.position[k] - position[k]) < 0.01 * size, `the double-click hit the point the probe shows there: ${pick.position} vs ${position}`);
  let now = await view();
  assert.deepEqual(now.camera.target, pick.position, 'the point hit is the rotation centre');
  let centre = project(now.camera, now.width, now.height, pick.position);
  assert.ok(Math.hypot(centre[0] - now.width / 2, centre[1] - now.height / 2) < 1, `and in the middle of the view: ${centre}`);
  assert.ok(await page.isHidden('#probe'), "the clicks' probe popup is not shown");
  assert.match(await page.textContent('#view-note'), /Rotation centre/);
  await page.keyboard.press('ArrowLeft');  // a turn about it keeps it in the middle
  await settled();
  now = await view();
  centre = project(now.camera, now.width, now.height, pick.position);
  assert.ok(Math.hypot(centre[0] - now.width / 2, centre[1] - now.height / 2) < 1, `after a turn: ${centre}`);
});

test('ctrl+drag zooms to the box drawn', async () => {
  await page.keyboard.press('r');
  await settled();
  const before = await view();
  const probe = await pointOnData([[0.1, 0.05], [-0.1, 0.05]]);
  const [x, y] = await canvasPoint(probe.pixel);
  await page.keyboard.down('Control');
  await page.mouse.move(x - 40, y - 25);
  await page.mouse.down();
  await page.mouse.move(x + 40, y + 25, { steps: 5 });
  await page.mouse.up();
  await page.keyboard.up('Control');
  await settled();
  const after = await view();
  const ratio = distance(after.camera) / distance(before.camera);
  const box = await page.locator('#frame').boundingBox();
  const share = Math.max(80 / box.width, 50 / box.height);
  assert.ok(Math.abs(ratio - share) < 0.01, `the distance scaled by the box's share of the view (${share.toFixed(3)}): ${ratio.toFixed(3)}`);
  // the box's middle, on the plane through the old rotation centre, is the new one
  const middle = project(before.camera, before.width, before.height, after.camera.target);
  assert.ok(Math.hypot(middle[0] - probe.pixel[0], middle[1] - probe.pixel[1]) < 2, `the new centre was under the box's middle: ${middle} vs ${probe.pixel}`);
});

test('the Zoom box button arms a box for the next drag; Escape disarms it', async () => {
  await page.click('#zoom-box-button');
  assert.equal(await page.getAttribute('#zoom-box-button', 'aria-pressed'), 'true');
  await page.locator('#frame').focus();
  await page.keyboard.press('Escape');
  assert.equal(await page.getAttribute('#zoom-box-button', 'aria-pressed'), 'false');
  await page.keyboard.press('b');
  assert.equal(await page.getAttribute('#zoom-box-button', 'aria-pressed'), 'true', 'b arms it too');
  await page.keyboard.press('r');
  await settled();
  const before = await view();
  const box = await page.locator('#frame').boundingBox();
  const [x, y] = [box.x + box.width / 2, box.y + box.height / 2];
  await page.mouse.move(x - 60, y - 30);
  await page.mouse.down();
  await page.mouse.move(x + 60, y + 30, { steps: 4 });
  await page.mouse.up();
  await settled();
  const ratio = distance((await view()).camera) / distance(before.camera);
  assert.ok(Math.abs(ratio - Math.max(120 / box.width, 60 / box.height)) < 0.01, `a plain drag drew the box: the distance scaled by ${ratio.toFixed(3)}`);
  assert.equal(await page.getAttribute('#zoom-box-button', 'aria-pressed'), 'false', 'one box a press');
  await page.keyboard.press('r');
  await settled();
});

test('f and the Fit button frame what is visible: the box, or the part the clips keep', async () => {
  for (let i = 0; i < 8; ++i) await page.keyboard.press('+');  // far in, somewhere off the middle
  await page.keyboard.press('ArrowRight');
  await settled();
  let now = await view();
  assert.ok(!framing(now, boxCorners(now.bounds)).inside, 'zoomed in: the box is not all in the view');
  await page.keyboard.press('f');
  await settled();
  now = await view();
  let fit = framing(now, boxCorners(now.bounds));
  assert.ok(fit.inside && fit.fill > 0.8, `f: the box fills ${fit.fill.toFixed(2)} of the view, all inside: ${fit.inside}`);
  // a clip keeping x <= the middle: Fit frames that half
  await page.locator('[data-add=clip]').click();
  for (let i = 0; i < 6; ++i) await page.keyboard.press('+');
  await page.click('#fit-visible');
  await settled();
  now = await view();
  const middleX = (now.bounds.min[0] + now.bounds.max[0]) / 2;
  const kept = { min: now.bounds.min, max: [middleX, now.bounds.max[1], now.bounds.max[2]] };
  fit = framing(now, boxCorners(kept));
  assert.ok(fit.inside && fit.fill > 0.8, `Fit: the kept half fills ${fit.fill.toFixed(2)} of the view, all inside: ${fit.inside}`);
  assert.ok(now.camera.target[0] < middleX, 'the centre is in the kept half');
  await page.locator('.plane-row[data-kind=clips] button').last().click();  // remove the clip
  await settled();
});

test('view presets look along their direction and frame the data from there', async () => {
  for (const [key, direction] of [['x', [1, 0, 0]], ['Shift+Y', [0, -1, 0]], ['z', [0, 0, 1]]]) {
    for (let i = 0; i < 6; ++i) await page.keyboard.press('+');
    await page.keyboard.press(key);
    await settled();
    const now = await view();
    const look = now.camera.target.map((t, i) => t - now.camera.eye[i]);
    const length = Math.hypot(...look);
    assert.ok(look.every((v, i) => Math.abs(v / length - direction[i]) < 1e-9), `${key} looks along ${direction}: ${look}`);
    const fit = framing(now, boxCorners(now.bounds));
    assert.ok(fit.inside && fit.fill > 0.8, `${key}: the box fills ${fit.fill.toFixed(2)} of the view, all inside: ${fit.inside}`);
  }
  await page.keyboard.press('r');
  await settled();
});
