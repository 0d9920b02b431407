// Time series in headless Chromium: a .pvd series of four steps (a 10^3 grid of cubes, 5 tets
// each, whose scalar moves along x from step to step) preprocessed into one store. The Time
// panel lists its steps; the slider shows a step (time.set; the image changes, the URL says
// step=); Play advances through the steps, each sent once the frame of the step before is on
// the screen with the next one as its prefetch, wrapping round; Pause sends the step shown
// alone and the view refines to a still of it; a link with step= opens on that step.
//   node --test tests/browser/time.test.mjs   (TETRA_BINARY: the tetrascope executable)
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { mkdtempSync, writeFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { clientErrors, frameImage, lastSent, settled as settledOn, startViewer } from './harness.mjs';

const kSteps = 4;
const kCells = 10;

// A VTU of the grid with step s's scalar, and the .pvd naming the steps (times 0, 0.5, ...).
function writeSeries(dir) {
  const n = kCells + 1;
  const id = (i, j, l) => (l * n + j) * n + i;
  const points = [];
  for (let l = 0; l < n; ++l) for (let j = 0; j < n; ++j) for (let i = 0; i < n; ++i) points.push(i / kCells, j / kCells, l / kCells);
  const tets = [];
  const five = [
    [[0, 1, 2, 5], [0, 2, 3, 7], [0, 4, 5, 7], [2, 5, 6, 7], [0, 2, 5, 7]],
    [[0, 1, 3, 4], [1, 2, 3, 6], [1, 4, 5, 6], [3, 4, 6, 7], [1, 3, 4, 6]],
  ];
  for (let l = 0; l < kCells; ++l)
    for (let j = 0; j < kCells; ++j)
      for (let i = 0; i < kCells; ++i) {
        const c = [id(i, j, l), id(i + 1, j, l), id(i + 1, j + 1, l), id(i, j + 1, l), id(i, j, l + 1), id(i + 1, j, l + 1), id(i + 1, j + 1, l + 1), id(i, j + 1, l + 1)];
        for (const t of five[(i + j + l) % 2]) tets.push(...t.map((k) => c[k]));
      }
  const cells = tets.length / 4;
  let pvd = '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n<Collection>\n';
  for (let s = 0; s < kSteps; ++s) {
    const values = [];
    for (let v = 0; v < points.length / 3; ++v) values.push(Math.exp(-30 * (points[3 * v] - 0.2 - 0.2 * s) ** 2).toFixed(6));
    const vtu =
      '<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">\n<UnstructuredGrid>\n' +
      `<Piece NumberOfPoints="${points.length / 3}" NumberOfCells="${cells}">\n` +
      `<PointData><DataArray type="Float32" Name="heat" format="ascii">${values.join(' ')}</DataArray></PointData>\n` +
      `<Points><DataArray type="Float32" NumberOfComponents="3" format="ascii">${points.join(' ')}</DataArray></Points>\n` +
      `<Cells><DataArray type="Int64" Name="connectivity" format="ascii">${tets.join(' ')}</DataArray>\n` +
      `<DataArray type="Int64" Name="offsets" format="ascii">${Array.from({ length: cells }, (_, c) => 4 * (c + 1)).join(' ')}</DataArray>\n` +
      `<DataArray type="UInt8" Name="types" format="ascii">${Array(cells).fill(10).join(' ')}</DataArray></Cells>\n` +
      '</Piece>\n</UnstructuredGrid>\n</VTKFile>\n';
    writeFileSync(join(dir, `heat_${s}.vtu`), vtu);
    pvd += `<DataSet timestep="${0.5 * s}" part="0" file="heat_${s}.vtu"/>\n`;
  }
  writeFileSync(join(dir, 'heat.pvd'), pvd + '</Collection>\n</VTKFile>\n');
  return join(dir, 'heat.pvd');
}

let viewer, page, inputs;

before(async () => {
  inputs = mkdtempSync(join(tmpdir(), 'tetrascope-series-'));
  viewer = await startViewer({ prefix: 'tetrascope-time-', mesh: writeSeries(inputs), name: 'heat', build: ['--segment-tets', '1024', '--base-tets', '1000'], open: true });
  page = viewer.page;
});

after(async () => {
  await viewer?.stop();
  rmSync(inputs, { recursive: true, force: true });
});

const settled = () => settledOn(page, 200);
const step = () => page.evaluate(() => window.tetrascope.view.timeStep);

test('the Time panel lists the steps of the series', { timeout: 120000 }, async () => {
  const steps = await page.evaluate(() => window.tetrascope.dataset.time_steps);
  assert.equal(steps.length, kSteps);
  assert.deepEqual(steps.map((s) => s.time), [0, 0.5, 1, 1.5]);
  assert.deepEqual(steps.map((s) => s.name), ['heat_0.vtu', 'heat_1.vtu', 'heat_2.vtu', 'heat_3.vtu']);
  assert.ok(await page.locator('#time-panel').isVisible());
  assert.equal(await page.locator('#time-step').getAttribute('max'), String(kSteps - 1));
  assert.match(await page.locator('#time-label').innerText(), /step 1 of 4\s+t = 0\s+heat_0\.vtu/);
  // the colour range is the series' (heat reaches 1 at every step): the same colours at every step
  const attribute = await page.evaluate(() => window.tetrascope.dataset.attributes[0]);
  assert.ok(attribute.series_range[1] >= attribute.range[1]);
});

test('the slider shows a step: time.set, another image, step= in the URL', { timeout: 120000 }, async () => {
  await settled();
  const first = await frameImage(page);
  await page.evaluate(() => {  // the slider dragged to step 2
    const slider = document.getElementById('time-step');
    slider.value = '2';
    slider.dispatchEvent(new Event('input', { bubbles: true }));
  });
  await settled();
  assert.deepEqual(await lastSent(page, 'time.set'), { step: 2 });
  assert.equal(await step(), 2);
  assert.notEqual(await frameImage(page), first, 'step 2 drew the image of step 0');
  assert.match(await page.evaluate(() => location.hash), /step=2/);
  assert.match(await page.locator('#time-label').innerText(), /step 3 of 4\s+t = 1\s+heat_2\.vtu/);
  assert.deepEqual(await clientErrors(page), []);
});

test('Play advances step by step with the next step prefetched, wrapping round; Pause refines the step shown', { timeout: 180000 }, async () => {
  await page.selectOption('#time-rate', '0');  // as fast as frames come
  const before = await page.evaluate(() => window.tetrascope.sent.filter((m) => m.type === 'time.set').length);
  await page.locator('#time-play').click();
  assert.equal(await page.locator('#time-play').innerText(), 'Pause');
  // six steps shown: from step 2 through 3, 0 (wrapped), 1, 2, 3 and 0
  await page.waitForFunction(() => window.tetrascope.time.stats.shown >= 6, null, { timeout: 120000 });
  await page.locator('#time-play').click();
  assert.equal(await page.locator('#time-play').innerText(), 'Play');
  const sent = await page.evaluate((n) => window.tetrascope.sent.filter((m) => m.type === 'time.set').slice(n).map((m) => m.body), before);
  assert.ok(sent.length >= 7, `${sent.length} steps sent`);
  const paused = sent.pop();  // Pause: the step shown, alone, to be refined
  sent.forEach((body, k) => {
    assert.equal(body.step, (2 + 1 + k) % kSteps, `the play's step ${k}`);
    assert.equal(body.prefetch, (body.step + 1) % kSteps, 'the step after it is prefetched');
  });
  assert.deepEqual(paused, { step: sent.at(-1).step });
  const rate = await page.evaluate(() => window.tetrascope.time.measuredRate());
  assert.ok(rate > 0, 'steps were shown while playing');
  console.log(`played ${sent.length} steps at ${rate.toFixed(1)} steps/s (headless Chromium, llvmpipe, 5000 tets)`);
  await settled();  // paused: the step shown refines to a still
  const shown = await step();
  assert.equal(sent.at(-1).step, shown);
  assert.deepEqual(await clientErrors(page), []);
});

test('a link with step= opens on that step', { timeout: 120000 }, async () => {
  const hash = await page.evaluate(() => location.hash);
  const url = new URL(page.url());
  url.hash = hash.replace(/step=\d+/, 'step=3');
  await page.goto('about:blank');
  await page.goto(url.toString());
  await settled();
  assert.equal(await step(), 3);
  assert.deepEqual(await lastSent(page, 'time.set'), { step: 3 });
  assert.equal(await page.locator('#time-step').inputValue(), '3');
});
