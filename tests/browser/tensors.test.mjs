// A tensor field in the web client, in headless Chromium: a box whose diffusion tensor is
// linear along x below z = 0.5 and planar (normal z) above, preprocessed by the real
// `tetrascope preprocess` and served; turning "tubes and surfaces" on sends tensors.set and a
// mode with tensors, changes the image and shows the anisotropy classes' legend; colouring by a
// derived quantity shows its colour bar over the dataset's range; the seeding changes the image;
// the state is in the URL and every message sent passes the codec.
//   node --test tests/browser/tensors.test.mjs   (TETRA_BINARY: the tetrascope executable)
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { mkdtempSync, writeFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { startViewer, frameImage as imageOf, settled as settledOn, lastSent as lastSentOn, clientErrors } from './harness.mjs';

let viewer, page, folder;

// n^3 cubes of the unit box, six tets each, with a scalar f = x and the tensor D.
function writeLayers(path, n) {
  const id = (i, j, k) => (k * (n + 1) + j) * (n + 1) + i;
  const points = [], f = [], tensors = [], cells = [];
  for (let k = 0; k <= n; ++k)
    for (let j = 0; j <= n; ++j)
      for (let i = 0; i <= n; ++i) {
        const [x, y, z] = [i / n, j / n, k / n];
        points.push(`${x} ${y} ${z}`);
        f.push(x);
        const medium = z < 0.5 ? 0.15 : 0.9;
        tensors.push(`1 0 0\n0 ${medium} 0\n0 0 0.05`);
      }
  for (let k = 0; k < n; ++k)
    for (let j = 0; j < n; ++j)
      for (let i = 0; i < n; ++i) {
        const c = [0, 1, 2, 3, 4, 5, 6, 7].map((b) => id(i + (b & 1), j + ((b >> 1) & 1), k + ((b >> 2) & 1)));
        for (const [a, b] of [[1, 3], [1, 5], [2, 3], [2, 6], [4, 5], [4, 6]]) cells.push(`4 ${c[0]} ${c[a]} ${c[b]} ${c[7]}`);
      }
  const text = ['# vtk DataFile Version 3.0', 'tensor layers', 'ASCII', 'DATASET UNSTRUCTURED_GRID', `POINTS ${points.length} double`, ...points,
    `CELLS ${cells.length} ${5 * cells.length}`, ...cells, `CELL_TYPES ${cells.length}`, ...cells.map(() => '10'),
    `POINT_DATA ${points.length}`, 'SCALARS f double 1', 'LOOKUP_TABLE default', ...f.map(String), 'TENSORS D double', ...tensors].join('\n');
  writeFileSync(path, `${text}\n`);
}

before(async () => {
  folder = mkdtempSync(join(tmpdir(), 'tetrascope-tensor-mesh-'));
  const mesh = join(folder, 'layers.vtk');
  writeLayers(mesh, 8);
  viewer = await startViewer({ prefix: 'tetrascope-tensors-', mesh, name: 'layers', build: [], open: true });
  page = viewer.page;
});

after(async () => {
  await viewer?.stop();
  if (folder) rmSync(folder, { recursive: true, force: true });
});

const frameImage = () => imageOf(page);
const settled = () => settledOn(page);
const lastSent = (type) => lastSentOn(page, type);

test('tubes and surfaces turn on with a legend of the anisotropy classes', async () => {
  assert.equal(await page.isDisabled('#tensors-on'), false, 'the dataset has a tensor');
  assert.equal(await page.inputValue('#tensors-field'), 'D');
  assert.equal(await page.locator('#legend [data-key="tensors"]').count(), 0, 'no tensor legend while off');
  const before = await frameImage();
  await page.check('#tensors-on');
  await settled();
  assert.match((await lastSent('mode.set')).mode, /tensors/);
  const sent = await lastSent('tensors.set');
  assert.equal(sent.field, 'D');
  assert.equal(sent.density, 8);
  assert.notEqual(await frameImage(), before, 'the points show');
  const legend = page.locator('#legend [data-key="tensors"]');
  assert.equal(await legend.count(), 1);
  assert.deepEqual(await legend.locator('.legend-class').allTextContents(), ['linear (tubes)', 'planar (surfaces)', 'isotropic']);
  assert.match(page.url(), /mode=[^&]*tensors/);
  assert.deepEqual(await clientErrors(page), []);
});

test('a derived quantity colours the points with its colour bar; the seeding changes the image', async () => {
  const classes = await frameImage();
  await page.selectOption('#tensors-color', 'fa');
  await settled();
  assert.equal((await lastSent('tensors.set')).color, 'fa');
  assert.notEqual(await frameImage(), classes, 'coloured by fractional anisotropy');
  const legend = page.locator('#legend [data-key="tensors"]');
  assert.equal(await legend.locator('.legend-bar').count(), 1, 'a colour bar');
  assert.equal(await legend.locator('.legend-title').textContent(), 'D.fa');
  assert.match(page.url(), /tcolor=fa/);
  const byFa = await frameImage();
  await page.fill('#tensors-surfaces', '0');
  await page.dispatchEvent('#tensors-surfaces', 'change');
  await settled();
  assert.equal((await lastSent('tensors.set')).surface_density, 0);
  assert.notEqual(await frameImage(), byFa, 'no surfaces');
  assert.match(page.url(), /tsurf=0/);
  await page.uncheck('#tensors-on');
  await settled();
  assert.doesNotMatch((await lastSent('mode.set')).mode, /tensors/);
  assert.equal(await page.locator('#legend [data-key="tensors"]').count(), 0);
  assert.deepEqual(await clientErrors(page), []);
});
