// A small body in a huge far field, in headless Chromium: the ONERA M6 wing (about 1.2 units,
// at the origin, in the symmetry plane y = 0 of a far-field hemisphere of radius 100; shared
// data, ../shared/data/onera_m6_potential.vtk) is reached from the opening view in three
// counted actions: Add slice (the new slice is the plane z = 0 through the middle of the box,
// the wing's own plane), shift+z (look along -Z, the preset frames the hemisphere), and a
// ctrl+drag box of 8 px drawn over the middle of the symmetry plane's edge, where the wing's
// root is. The wing then spans a third of the view: measured with the server's probe over a
// grid of pixels (the hits on the wing's surface, through its hole in the slice). A double-click
// on the wing then makes it the rotation centre. Skipped when the shared data is absent.
//   node --test tests/browser/onera.test.mjs   (TETRA_BINARY: the tetrascope executable)
//   TETRA_DOC_IMAGES=docs/images: also writes onera-wing.png, the view reached
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { existsSync } from 'node:fs';
import { join } from 'node:path';
import { root, settled as settledOn, startViewer } from './harness.mjs';
import { project } from './projection.mjs';

const onera = join(root, '..', 'shared', 'data', 'onera_m6_potential.vtk');
const absent = existsSync(onera) ? false : `no ${onera}: the shared data is not here`;
// the wing's box, a little loose: root chord 0.81 from x = 0, 30° sweep, semi-span 1.2
const kWing = { min: [-0.1, 0.002, -0.1], max: [1.3, 1.25, 0.1] };
const onWing = (r) => r.hit && r.surface === 'boundary' && r.position.every((v, k) => v >= kWing.min[k] && v <= kWing.max[k]);

let viewer, page;

before(async () => {
  if (absent) return;
  viewer = await startViewer({ prefix: 'tetrascope-onera-', mesh: onera, name: 'onera', build: [], viewport: { width: 900, height: 560 }, open: true });
  page = viewer.page;
});

after(async () => {
  await viewer?.stop();
});

const view = () => page.evaluate(() => ({ camera: window.tetrascope.view.camera, width: document.getElementById('frame').width, height: document.getElementById('frame').height }));

// The probe over a grid of the canvas's pixels, one at a time.
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

test('the ONERA M6 wing is reached from the opening view in three actions', { skip: absent, timeout: 600000 }, async () => {
  const actions = [];
  const act = async (name, doIt) => {
    actions.push(name);
    await doIt();
    await settledOn(page, 0);
  };
  await act('click Add slice', () => page.locator('[data-add=slice]').click());
  await act('press shift+z', () => page.keyboard.press('Shift+Z'));
  // where the wing's root is now: the middle of the symmetry plane's edge (the test knows the
  // geometry; a user sees the edge and the half disc)
  const framed = await view();
  const root = project(framed.camera, framed.width, framed.height, [0.6, 0.6, 0]);
  const frame = await page.locator('#frame').boundingBox();
  const scale = frame.width / framed.width;
  const [x, y] = [frame.x + root[0] * scale, frame.y + root[1] * scale];
  await act('ctrl+drag an 8 px box over the wing root', async () => {
    await page.keyboard.down('Control');
    await page.mouse.move(x - 4, y - 4);
    await page.mouse.down();
    await page.mouse.move(x + 4, y + 4, { steps: 4 });
    await page.mouse.up();
    await page.keyboard.up('Control');
  });
  assert.ok(actions.length <= 3, `${actions.length} actions: ${actions.join(', ')}`);
  if (process.env.TETRA_DOC_IMAGES) {  // the image without the stats box
    await page.evaluate(() => (document.getElementById('stats').hidden = true));
    await page.locator('#view').screenshot({ path: join(process.env.TETRA_DOC_IMAGES, 'onera-wing.png') });
    await page.evaluate(() => (document.getElementById('stats').hidden = false));
  }

  const [columns, rows] = [24, 18];
  const grid = await probeGrid(columns, rows);
  const wing = grid.filter(onWing);
  // the share of the view between the outermost pixels on the wing, a grid cell included
  const extent = (k, cells) => (wing.length ? (Math.max(...wing.map((r) => r.pixel[k])) - Math.min(...wing.map((r) => r.pixel[k]))) / framed[k ? 'height' : 'width'] + 1 / cells : 0);
  const across = extent(0, columns), down = extent(1, rows);
  assert.ok(wing.length >= 12, `the wing under ${wing.length} of ${grid.length} probed pixels`);
  assert.ok(Math.max(across, down) >= 0.3, `the wing spans ${(100 * across).toFixed(0)}% of the width and ${(100 * down).toFixed(0)}% of the height`);

  // a double-click on the wing: the rotation centre on its surface
  const target = wing[Math.floor(wing.length / 2)];
  const box = await page.locator('#frame').boundingBox();
  const picks = await page.evaluate(() => window.tetrascope.picks.length);
  await page.mouse.dblclick(box.x + target.pixel[0] * scale, box.y + target.pixel[1] * scale);
  await page.waitForFunction((n) => window.tetrascope.picks.length > n, picks);
  await settledOn(page, 0);
  const pick = await page.evaluate(() => window.tetrascope.picks.at(-1));
  assert.ok(onWing(pick), `the double-click hit the wing: ${JSON.stringify(pick)}`);
  assert.deepEqual((await view()).camera.target, pick.position, 'the wing point is the rotation centre');
});
