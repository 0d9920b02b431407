// A store of the binary segment hierarchy (preprocess --model binary, §6.2) in the viewer, as
// a multi-triangulation store is shown: dataset.info names the model, the first still comes,
// a camera reset refines through steps of more tets to a still, and a drag gets moving frames
// that end in a still.
//   node --test tests/browser/models.test.mjs   (TETRA_BINARY: the tetrascope executable)
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { startViewer, settled as settledOn } from './harness.mjs';

let viewer, page;

before(async () => {
  viewer = await startViewer({
    prefix: 'tetrascope-binary-',
    build: ['--model', 'binary', '--segment-tets', '2000', '--base-tets', '3000', '--vertices', 'off'],
    serveArgs: ['--frame-ms', '5', '--refine-growth', '2'],
    open: true,
  });
  ({ page } = viewer);
});

after(async () => {
  await viewer?.stop();
});

const settled = () => settledOn(page, 0);

test('a binary hierarchy store opens and names its model', async () => {
  const info = await page.evaluate(() => window.tetrascope.dataset);
  assert.equal(info?.model, 'binary', `dataset.info: ${JSON.stringify(info)?.slice(0, 300)}`);
  assert.ok(info.levels >= 2, `levels: ${info.levels}`);
  const last = await page.evaluate(() => window.tetrascope.lastFrame.header);
  assert.ok(last.still && last.tets > 0, JSON.stringify(last));
});

test('a camera jump refines the binary hierarchy step by step to a still', async () => {
  await page.evaluate(() => {
    window.seen = [];
    window.tetrascope.onFrame = (h) => window.seen.push({ still: h.still, refining: h.refining, tets: h.tets, id: h.message_id });
  });
  await page.keyboard.press('r');  // the camera reset: refined again from the coarsest cut
  await settled();
  const seen = await page.evaluate(() => window.seen);
  const steps = seen.filter((f) => f.id === seen.at(-1).id);
  assert.ok(steps.length >= 2, `refinement steps: ${JSON.stringify(steps)}`);
  for (let i = 1; i < steps.length; ++i) assert.ok(steps[i].tets >= steps[i - 1].tets, `more tets each step: ${JSON.stringify(steps)}`);
  assert.ok(steps.at(-1).still);
  assert.ok(steps.at(-1).tets > steps[0].tets, `the still holds more tets than the first step: ${JSON.stringify(steps)}`);
});

test('a drag on a binary hierarchy store gets moving frames and a still', async () => {
  await page.evaluate(() => {
    window.seen = [];
    window.tetrascope.onFrame = (h) => window.seen.push({ still: h.still, id: h.message_id });
  });
  const box = await page.locator('#frame').boundingBox();
  await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
  await page.mouse.down();
  for (let i = 1; i <= 8; ++i) await page.mouse.move(box.x + box.width / 2 + 20 * i, box.y + box.height / 2 + 5 * i);
  await page.mouse.up();
  await settled();
  const seen = await page.evaluate(() => window.seen);
  assert.ok(seen.some((f) => !f.still), `moving frames during the drag: ${JSON.stringify(seen)}`);
  assert.ok(seen.at(-1).still, 'the drag ends in a still');
});
