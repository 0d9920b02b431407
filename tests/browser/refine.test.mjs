// Progressive refinement in headless Chromium: after a drag the viewer shows refinement
// steps (progress bar, tets and estimated error) ending in a still; a drag that starts while
// a refinement step is on the screen gets moving frames at once (the server drops the step),
// and the view then refines to its own still. Ordering only, no timed assertions.
//   node --test tests/browser/refine.test.mjs   (TETRA_BINARY: the tetrascope executable)
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { startViewer, settled as settledOn } from './harness.mjs';

let viewer, url, page;

before(async () => {
  // 5 ms frames, steps doubling: even the 45K-tet sample refines in several steps
  viewer = await startViewer({ prefix: 'tetrascope-refine-', serveArgs: ['--frame-ms', '5', '--refine-growth', '2'], viewport: { width: 1100, height: 700 } });
  ({ url, page } = viewer);
});

after(async () => {
  await viewer?.stop();
});

const settled = () => settledOn(page, 0);

test('refinement steps show progress and end in a still', async () => {
  await page.goto(url);
  await settled();
  // record every frame from here on
  await page.evaluate(() => {
    window.seen = [];
    window.tetrascope.onFrame = (h) =>
      window.seen.push({ still: h.still, refining: h.refining, tets: h.tets, error: h.estimated_error, id: h.message_id,
        bar: document.getElementById('refine-progress').dataset.state, text: document.getElementById('stats').textContent });
  });
  await page.keyboard.press('r');  // a camera jump: refinement at once
  await settled();
  const seen = await page.evaluate(() => window.seen);
  const steps = seen.filter((f) => f.id === seen.at(-1).id);
  assert.ok(steps.length >= 2, `refinement steps before the still: ${JSON.stringify(steps)}`);
  assert.ok(steps.at(-1).still);
  for (const [i, f] of steps.entries()) {
    if (i + 1 < steps.length) {
      assert.ok(f.refining, `step ${i} is flagged refining`);
      assert.equal(f.bar, 'refining', 'the progress bar shows while refining');
      assert.match(f.text, /refining/);
    }
    if (i > 0) assert.ok(f.tets >= steps[i - 1].tets, 'more tets each step');
    assert.match(f.text, /estimated error/);
  }
  assert.equal(steps.at(-1).bar, 'still');
  assert.equal(await page.locator('#refine-progress').isHidden(), true, 'the bar goes with the still');
});

test('a drag during refinement gets frames at once and refines to its own still', async () => {
  // when the first refinement step is on the screen, a drag starts (pointer events on the canvas)
  await page.evaluate(() => {
    window.drag = null;
    window.seen = [];
    window.tetrascope.onFrame = (h) => {
      window.seen.push({ still: h.still, refining: h.refining, id: h.message_id });
      if (!h.refining || window.drag) return;
      const canvas = document.getElementById('frame');
      const box = canvas.getBoundingClientRect();
      const x = box.left + box.width / 2, y = box.top + box.height / 2;
      const at = (dx) => ({ pointerId: 1, button: 0, buttons: 1, clientX: x + dx, clientY: y + dx / 2, bubbles: true, isPrimary: true, pointerType: 'mouse' });
      const before = window.tetrascope.sent.length;
      canvas.dispatchEvent(new PointerEvent('pointerdown', at(0)));
      canvas.dispatchEvent(new PointerEvent('pointermove', at(12)));  // the first move now, the rest as a hand would
      for (let i = 2; i <= 16; ++i) setTimeout(() => canvas.dispatchEvent(new PointerEvent('pointermove', at(12 * i))), 40 * i);
      window.drag = { seenBefore: window.seen.length, sentBefore: before, stillsBefore: window.tetrascope.stills };
      setTimeout(() => { canvas.dispatchEvent(new PointerEvent('pointerup', at(192))); window.drag.up = true; }, 40 * 17);
    };
  });
  await page.keyboard.press('ArrowLeft');  // a preset move: refinement starts
  await page.waitForFunction(() => window.drag, null, { timeout: 60000 });
  // the drag's camera messages went out
  const dragIds = await page.evaluate(() => {
    const sent = window.tetrascope.sent.slice(window.drag.sentBefore).filter((m) => m.type === 'camera.set' && m.body.interacting);
    return sent.length;
  });
  assert.ok(dragIds > 0, 'the drag sent camera.set messages');
  await page.waitForFunction(() => window.drag.up, null, { timeout: 60000 });
  await settled();
  const { seen, drag } = await page.evaluate(() => ({ seen: window.seen, drag: window.drag }));
  const after = seen.slice(drag.seenBefore);
  // the first frame after the drag began is a moving frame of the drag, not the old view's still
  const firstMoving = after.findIndex((f) => !f.still && !f.refining);
  const firstStill = after.findIndex((f) => f.still);
  assert.ok(firstMoving >= 0, `a moving frame answered the drag: ${JSON.stringify(after)}`);
  assert.ok(firstStill > firstMoving, `the drag got a frame before any still: ${JSON.stringify(after)}`);
  assert.equal(drag.stillsBefore, (await page.evaluate(() => window.tetrascope.stills)) - 1, 'one still in the end: the dragged view\'s');
});
