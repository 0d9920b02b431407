// The viewer's modes in any combination, in headless Chromium: a slice alone (volume,
// isosurface and boundary all off, nothing checked again behind the user's back), clip with
// the boundary, boundary with stream lines; and each refines on its own: with the volume off or
// at 0% opacity, the still of a slice or of the boundary holds as many tets as the boundary
// alone gets, not the coarsest level's, whether the store refines by vertices or by segments,
// and the stills of a clip with the boundary and of the boundary with lines are refined too.
//   node --test tests/browser/modes.test.mjs   (TETRA_BINARY: the tetrascope executable)
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { join } from 'node:path';
import { binary, sample, startViewer, frameImage as imageOf, settled as settledOn, lastSent as lastSentOn, clientErrors } from './harness.mjs';

let viewer, page;

before(async () => {
  viewer = await startViewer({ prefix: 'tetrascope-modes-', viewport: { width: 900, height: 700 } });
  // the same sample without a vertex hierarchy: the segment cut, as meshes over 8M tets get
  execFileSync(binary, ['preprocess', sample, '-o', join(viewer.data, 'segments'), '--segment-tets', '2000', '--base-tets', '3000', '--vertices', 'off', '--progress', 'none']);
  page = viewer.page;
  await page.goto(viewer.url);
  await settled();
});

after(async () => {
  await viewer?.stop();
});

const settled = () => settledOn(page, 100);
const frameImage = () => imageOf(page);
const lastSent = (type) => lastSentOn(page, type);
const stillTets = () => page.evaluate(() => window.tetrascope.lastStill.header.tets);
const modes = () => page.evaluate(() => ['dvr', 'iso', 'surface'].filter((m) => document.getElementById(`mode-${m}`).checked));

// The share of the canvas's pixels that differ from its corner (the background).
const covered = () =>
  page.evaluate(() => {
    const c = document.getElementById('frame'), g = c.getContext('2d');
    const { data } = g.getImageData(0, 0, c.width, c.height);
    let n = 0;
    for (let i = 0; i < data.length; i += 4) if (Math.abs(data[i] - data[0]) + Math.abs(data[i + 1] - data[1]) + Math.abs(data[i + 2] - data[2]) > 30) n += 1;
    return n / (data.length / 4);
  });

const setModes = async (on) => {
  for (const m of ['dvr', 'iso', 'surface']) await page.setChecked(`#mode-${m}`, on.includes(m));
  await settled();
};

test('the boundary alone refines fully', async () => {
  await setModes(['surface']);
  assert.equal((await lastSent('mode.set')).mode, 'surface');
  const tets = await stillTets();
  const total = await page.evaluate(() => window.tetrascope.dataset.tets);
  assert.ok(tets > 0.5 * total, `the boundary's still holds ${tets} of ${total} tets`);
});

test('a slice alone: nothing else checked again, the slice shows, refined, and a link keeps it', async () => {
  await setModes([]);
  assert.deepEqual(await modes(), [], 'volume, isosurface and boundary stay unchecked');
  assert.equal((await lastSent('mode.set')).mode, 'slice', 'the mode sent: the slice planes alone');
  const empty = await covered();
  await page.click('[data-add=slice]');
  await settled();
  assert.deepEqual(await modes(), [], 'adding a slice checks nothing');
  const shown = await covered();
  assert.ok(shown > empty + 0.02, `the slice covers ${(100 * shown).toFixed(1)}% of the view, ${(100 * empty).toFixed(1)}% before`);
  // the attribute's legend names what it colours: the slice, not a volume that is off
  assert.equal(await page.textContent('#legend .legend[data-key=attribute] .legend-caption'), 'slice');
  const total = await page.evaluate(() => window.tetrascope.dataset.tets);
  const tets = await stillTets();
  assert.ok(tets > 0.5 * total, `the slice's still holds ${tets} of ${total} tets (the volume is off: its opacity ranks nothing)`);
  assert.match(page.url(), /mode=slice(&|$)/);
  await page.reload();
  await settled();
  assert.deepEqual(await modes(), [], 'the link opens with the slice alone');
  assert.equal((await lastSent('mode.set')).mode, 'slice');
  assert.equal((await page.evaluate(() => window.tetrascope.view.slices.length)), 1);
});

// The still's tets of the boundary alone, then with the volume at 0% opacity.
async function boundaryStills() {
  await setModes(['surface']);
  const alone = await stillTets();
  await setModes(['dvr', 'surface']);
  await page.evaluate(() => {
    const slider = document.getElementById('opacity-scale');
    slider.value = '0';
    slider.dispatchEvent(new Event('input'));
  });
  await settled();
  const transparent = await stillTets();
  await page.click('#tf-reset');
  await settled();
  return { alone, transparent };
}

test('the volume at 0% opacity with the boundary refines as the boundary alone, by vertices and by segments', async () => {
  for (const remove of await page.locator('.plane-row[data-kind=slices] .plane-remove').all()) await remove.click();  // the slice of the test before
  for (const dataset of ['disk', 'segments']) {
    await page.selectOption('#dataset', dataset);
    await page.waitForFunction((name) => window.tetrascope.dataset?.name === name, dataset);
    await settled();
    const { alone, transparent } = await boundaryStills();
    const total = await page.evaluate(() => window.tetrascope.dataset.tets);
    assert.ok(alone > 0.5 * total, `${dataset}: the boundary alone's still holds ${alone} of ${total} tets`);
    assert.ok(transparent >= 0.9 * alone, `${dataset}: with a transparent volume the boundary's still holds ${transparent} tets, alone ${alone}`);
  }
  await page.selectOption('#dataset', 'disk');
  await page.waitForFunction(() => window.tetrascope.dataset?.name === 'disk');
  await settled();
});

test('clip with the boundary, and the boundary with stream lines', async () => {
  await setModes(['surface']);
  const whole = await frameImage();
  await page.click('[data-add=clip]');
  await settled();
  assert.equal((await lastSent('mode.set')).mode, 'surface');
  assert.notEqual(await frameImage(), whole, 'the clip cut the boundary');
  const total = await page.evaluate(() => window.tetrascope.dataset.tets);
  // each refines on its own: the clip keeps half the box, and its still about half the tets
  const clippedTets = await stillTets();
  assert.ok(clippedTets > 0.4 * total, `clip with the boundary: the still holds ${clippedTets} of ${total} tets`);
  const clipped = await frameImage();
  await page.check('#lines-on');
  await settled();
  assert.equal((await lastSent('mode.set')).mode, 'surface+lines');
  assert.notEqual(await frameImage(), clipped, 'the lines show with the boundary');
  const linesTets = await stillTets();
  assert.ok(linesTets > 0.4 * total, `the boundary with stream lines: the still holds ${linesTets} of ${total} tets`);
  await page.uncheck('#mode-surface');
  await settled();
  assert.equal((await lastSent('mode.set')).mode, 'lines', 'the lines alone, no volume added');
  assert.deepEqual(await modes(), []);
  assert.deepEqual(await clientErrors(page), []);
});
