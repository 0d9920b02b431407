// Boundary regions in headless Chromium on the ONERA M6 wing (shared data,
// ../shared/data/onera_m6_potential.vtk: a wing of about 1.2 units on the symmetry plane y = 0
// of a far-field hemisphere of radius 100). The panel lists the boundary's regions; "Bodies
// only" hides the far field and the symmetry plane (the regions on the domain's box) and the
// wing is reached from the opening view in three counted actions: Bodies only, the volume off,
// f (Fit frames the regions shown). Then, on pixels: the boundary with every region covers the
// opening view, with bodies only the background is back where the far field was; unchecking
// the wing hides it, checking it shows it again; unchecking the far field alone leaves no probe
// hit on it. Skipped when the shared data is absent.
//   node --test tests/browser/regions.test.mjs   (TETRA_BINARY: the tetrascope executable)
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { existsSync } from 'node:fs';
import { join } from 'node:path';
import { clientErrors, lastSent, root, settled as settledOn, startViewer } from './harness.mjs';

const onera = join(root, '..', 'shared', 'data', 'onera_m6_potential.vtk');
const absent = existsSync(onera) ? false : `no ${onera}: the shared data is not here`;
// the wing's box, a little loose, off the symmetry plane (whose points have y = 0 within rounding)
const kWing = { min: [-0.1, 1e-5, -0.1], max: [1.5, 1.55, 0.1] };
const onWing = (r) => r.hit && r.surface === 'boundary' && r.position.every((v, k) => v >= kWing.min[k] && v <= kWing.max[k]);
const onFarField = (r) => r.hit && r.surface === 'boundary' && Math.hypot(...r.position) > 50 && r.position[1] > 1e-3;
const kBackground = [26, 26, 31];  // the renderer's background, (0.1, 0.1, 0.12)

let viewer, page;

before(async () => {
  if (absent) return;
  viewer = await startViewer({ prefix: 'tetrascope-regions-', mesh: onera, name: 'onera', build: [], viewport: { width: 900, height: 560 }, open: true });
  page = viewer.page;
});

after(async () => {
  await viewer?.stop();
});

const settled = () => settledOn(page, 200);
const regions = () => page.evaluate(() => window.tetrascope.dataset.regions);
const view = () => page.evaluate(() => ({ width: document.getElementById('frame').width, height: document.getElementById('frame').height }));

// Per pixel of the frame canvas: 1 where it differs from the background.
const litMask = () =>
  page.evaluate((bg) => {
    const canvas = document.getElementById('frame');
    const rgba = canvas.getContext('2d').getImageData(0, 0, canvas.width, canvas.height).data;
    const mask = [];
    for (let i = 0; i < rgba.length; i += 4) mask.push(Math.abs(rgba[i] - bg[0]) + Math.abs(rgba[i + 1] - bg[1]) + Math.abs(rgba[i + 2] - bg[2]) > 24 ? 1 : 0);
    return mask;
  }, kBackground);
const count = (mask) => mask.reduce((a, b) => a + b, 0);

async function probeGrid(columns, rows) {
  const { width, height } = await view();
  const results = [];
  for (let j = 0; j < rows; ++j)
    for (let i = 0; i < columns; ++i) {
      const pixel = [((i + 0.5) * width) / columns, ((j + 0.5) * height) / rows];
      results.push({ pixel, ...(await page.evaluate(([x, y]) => window.tetrascope.probePixel(x, y), pixel)) });
    }
  return results;
}

const checkbox = (id) => page.locator(`#regions input[data-region="${id}"]`);

test('the panel lists the regions: far field, symmetry plane and wing apart', { skip: absent, timeout: 600000 }, async () => {
  const list = await regions();
  assert.ok(list.length >= 3, `${list.length} regions`);
  const onBox = list.filter((r) => r.touches_domain_box);
  const bodies = list.filter((r) => !r.touches_domain_box);
  assert.equal(onBox.length, 2, 'the far field and the symmetry plane lie on the domain box');
  assert.ok(bodies.length >= 1 && bodies.every((r) => r.bounds.max.every((v) => Math.abs(v) < 2)), 'the bodies are the wing');
  assert.equal(await page.locator('#regions .region-row').count(), list.length);
  assert.match(await page.locator('#regions .region-row').first().innerText(), /region 0/);
  assert.ok(await page.locator('#boundary-panel').isVisible());
});

test('the ONERA M6 wing is reached from the opening view in three actions with Bodies only', { skip: absent, timeout: 600000 }, async () => {
  const actions = [];
  const act = async (name, doIt) => {
    actions.push(name);
    await doIt();
    await settled();
  };
  await act('click Bodies only', () => page.locator('#bodies-only').click());
  await act('uncheck volume', () => page.locator('#mode-dvr').uncheck());
  await act('press f', () => page.keyboard.press('f'));
  assert.ok(actions.length <= 3, `${actions.length} actions: ${actions.join(', ')}`);

  const list = await regions();
  const onBox = list.filter((r) => r.touches_domain_box).map((r) => r.id);
  assert.deepEqual(await lastSent(page, 'regions.set'), { hidden: onBox });
  assert.ok(await page.locator('#mode-surface').isChecked(), 'Bodies only shows the boundary');
  for (const r of list) assert.equal(await checkbox(r.id).isChecked(), !r.touches_domain_box, `region ${r.id}'s checkbox`);
  assert.match(await page.evaluate(() => location.hash), new RegExp(`hide=${onBox.join(',')}`), 'the link keeps the hidden regions');

  const { width, height } = await view();
  const [columns, rows] = [24, 18];
  const grid = await probeGrid(columns, rows);
  const wing = grid.filter(onWing);
  const extent = (k, cells) => (wing.length ? (Math.max(...wing.map((r) => r.pixel[k])) - Math.min(...wing.map((r) => r.pixel[k]))) / (k ? height : width) + 1 / cells : 0);
  assert.ok(wing.length >= 12, `the wing under ${wing.length} of ${grid.length} probed pixels`);
  assert.ok(Math.max(extent(0, columns), extent(1, rows)) >= 0.3, 'the wing spans a third of the view');
  const others = grid.filter((r) => r.hit && !onWing(r));
  assert.equal(others.length, 0, `hits off the wing: ${JSON.stringify(others.slice(0, 3))}`);
  assert.deepEqual(await clientErrors(page), []);
});

test('unchecking the wing hides it, checking it shows it again', { skip: absent, timeout: 600000 }, async () => {
  const wing = (await regions()).find((r) => !r.touches_domain_box);
  const shown = await litMask();
  assert.ok(count(shown) > shown.length / 20, `the wing covers ${count(shown)} pixels`);
  await checkbox(wing.id).uncheck();
  await settled();
  const hidden = await litMask();
  assert.ok(count(hidden) < hidden.length / 1000, `${count(hidden)} pixels off the background with every region hidden`);
  assert.ok((await lastSent(page, 'regions.set')).hidden.includes(wing.id));
  await checkbox(wing.id).check();
  await settled();
  assert.ok(count(await litMask()) > shown.length / 20, 'the wing is back');
});

test('with every region the boundary covers the opening view; Bodies only leaves the background where the far field was', { skip: absent, timeout: 600000 }, async () => {
  await page.keyboard.press('r');  // the opening view, the boundary alone, bodies only
  await settled();
  const bodiesOnly = await litMask();
  await page.locator('#all-regions').click();
  await settled();
  const all = await litMask();
  assert.deepEqual(await lastSent(page, 'regions.set'), { hidden: [] });
  assert.ok(count(all) > all.length / 10, `the boundary covers ${count(all)} of ${all.length} pixels`);
  // where the far field was: lit with every region, background with bodies only
  const uncovered = all.filter((lit, i) => lit && !bodiesOnly[i]).length;
  assert.ok(uncovered > 0.9 * count(all), `${uncovered} of ${count(all)} pixels back to the background`);
  assert.ok(count(bodiesOnly) < count(all) / 10);

  // the far field alone unchecked: the probe no longer meets it, and the image changed
  const grid = await probeGrid(8, 6);
  assert.ok(grid.some(onFarField), 'the far field is under some of the probed pixels');
  const farField = (await regions()).find((r) => r.touches_domain_box && r.bounds.max[1] > 50);
  await checkbox(farField.id).uncheck();
  await settled();
  const without = await litMask();
  assert.ok(without.some((lit, i) => lit !== all[i]), 'the image changed');
  const after = await probeGrid(8, 6);
  assert.equal(after.filter(onFarField).length, 0, 'no probe hit on the hidden far field');
  assert.deepEqual(await clientErrors(page), []);
});
