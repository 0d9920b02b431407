// The web client in headless Chromium (Debian's chromium, driven by playwright-core): the
// page loads, a drag rotates the view, a pan follows the cursor, the transfer-function
// editor (opacity and colour points, presets, overall opacity) changes the image, keys and
// presets move the camera, the whole view survives a reconnect and a link, a still is saved
// at a chosen size with its legend, the panel collapses on a phone, and an upload +
// preprocess job survives a reload and opens its dataset, a page that cannot load the dataset
// list says so and opens one once it comes, and a dataset can be deleted.
//   node --test tests/browser/viewer.test.mjs   (TETRA_BINARY: the tetrascope executable)
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { existsSync, readdirSync, readFileSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { startViewer, sample, frameImage as imageOf, settled as settledOn, lastSent as lastSentOn } from './harness.mjs';

const shots = process.env.TETRA_SCREENSHOTS;  // a folder: keep screenshots for inspection

let viewer, data, url, browser, page;

before(async () => {
  viewer = await startViewer({ prefix: 'tetrascope-browser-', viewport: { width: 900, height: 560 } });
  ({ data, url, browser, page } = viewer);
});

after(async () => {
  await viewer?.stop();
});

// a digest of the canvas, so that a failed comparison prints two short strings
const frameImage = () => imageOf(page);

// until a still frame shows everything the page asked for
const settled = (p = page) => settledOn(p);

async function shot(name, p = page) {
  if (shots) await p.screenshot({ path: join(shots, `${name}.png`) });
}

// the canvas's pixels: the centroid of those not background, and a 32x24 grey thumbnail
const canvasStats = (p = page) =>
  p.evaluate(() => {
    const c = document.getElementById('frame');
    const { data, width, height } = c.getContext('2d').getImageData(0, 0, c.width, c.height);
    const tw = 32, th = 24, thumb = new Array(tw * th).fill(0), counts = new Array(tw * th).fill(0);
    let sx = 0, sy = 0, n = 0;
    for (let y = 0; y < height; ++y)
      for (let x = 0; x < width; ++x) {
        const i = 4 * (y * width + x), r = data[i], g = data[i + 1], b = data[i + 2];
        const k = Math.floor((y * th) / height) * tw + Math.floor((x * tw) / width);
        thumb[k] += (r + g + b) / 3;
        counts[k] += 1;
        if (Math.abs(r - 26) + Math.abs(g - 26) + Math.abs(b - 31) > 24) [sx, sy, n] = [sx + x, sy + y, n + 1];
      }
    return { centroid: n ? [sx / n, sy / n] : null, count: n, thumb: thumb.map((v, k) => v / counts[k]) };
  });

// mean absolute difference of two thumbnails, in grey levels
const thumbDistance = (a, b) => a.thumb.reduce((sum, v, k) => sum + Math.abs(v - b.thumb[k]), 0) / a.thumb.length;

const lastSent = (type, p = page) => lastSentOn(p, type);

// the dimensions in a PNG's IHDR
const pngSize = (bytes) => [bytes.readUInt32BE(16), bytes.readUInt32BE(20)];

test('the page loads and a frame appears', async () => {
  await page.goto(url);
  await settled();
  const state = await page.evaluate(() => ({ frames: window.tetrascope.frames, dataset: window.tetrascope.dataset?.name, errors: window.tetrascope.errors }));
  assert.equal(state.dataset, 'disk');
  assert.ok(state.frames >= 1);
  assert.deepEqual(state.errors, []);
  assert.match(await page.textContent('#stats'), /tets/);
  const icon = await page.evaluate(async () => {
    const link = document.querySelector('link[rel=icon]');
    const response = await fetch(link.href);
    return { status: response.status, type: response.headers.get('content-type') };
  });
  assert.deepEqual(icon, { status: 200, type: 'image/svg+xml' }, 'a favicon');
  await shot('loaded');
});


test('a drag rotates the view', async () => {
  const before = await frameImage();
  const box = await page.locator('#frame').boundingBox();
  await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
  await page.mouse.down();
  for (let i = 1; i <= 10; ++i) await page.mouse.move(box.x + box.width / 2 + i * 15, box.y + box.height / 2 + i * 10);
  await page.mouse.up();
  await settled();
  assert.notEqual(await frameImage(), before, 'the image did not change');
  assert.match(page.url(), /eye=/, 'the view is saved in the URL');
  await shot('rotated');
});

test('a pan follows the cursor on both axes', async () => {
  await page.keyboard.press('r');  // the opening view: the object in the middle
  await settled();
  const box = await page.locator('#frame').boundingBox();
  const drag = async (dx, dy) => {
    const x = box.x + box.width / 2, y = box.y + box.height / 2;
    await page.mouse.move(x, y);
    await page.mouse.down({ button: 'right' });
    for (let i = 1; i <= 10; ++i) await page.mouse.move(x + (i * dx) / 10, y + (i * dy) / 10);
    await page.mouse.up({ button: 'right' });
    await settled();
  };
  const start = await canvasStats();
  assert.ok(start.count > 1000, 'the object shows');
  await drag(100, 0);
  const right = await canvasStats();
  const moved = [right.centroid[0] - start.centroid[0], right.centroid[1] - start.centroid[1]];
  assert.ok(moved[0] > 60 && moved[0] < 140, `a drag 100 px right moved the image ${moved[0].toFixed(0)} px across`);
  assert.ok(Math.abs(moved[1]) < 20, `and ${moved[1].toFixed(0)} px down`);
  await drag(0, 60);
  const down = await canvasStats();
  const movedDown = down.centroid[1] - right.centroid[1];
  assert.ok(movedDown > 35 && movedDown < 85, `a drag 60 px down moved the image ${movedDown.toFixed(0)} px down`);
  await page.keyboard.press('r');
  await settled();
});

test('the transfer-function editor changes the image', async () => {
  const before = await frameImage();
  await page.locator('#tf-editor').scrollIntoViewIfNeeded();  // below the vector and plane panels
  const box = await page.locator('#tf-editor').boundingBox();
  // drag the right end point of the opacity curve down to ~0.1 of its height
  const [, alpha] = await page.evaluate(() => window.tetrascope.opacityPoints().at(-1));
  const curveHeight = box.height * (1 - 18 / 136);
  await page.mouse.move(box.x + box.width - 1, box.y + (1 - alpha) * curveHeight);
  await page.mouse.down();
  await page.mouse.move(box.x + box.width - 1, box.y + curveHeight * 0.9, { steps: 5 });
  await page.mouse.up();
  await settled();
  assert.notEqual(await frameImage(), before, 'the image did not change');
  const opacity = await lastSent('tf.set').then((b) => b.opacity);
  assert.ok(opacity.at(-1)[1] < alpha, 'the end point went down');
  await page.click('#tf-reset');
  await settled();
  await shot('tf-edited');
});

test('colormap presets and colour points are sent as user colours', async () => {
  const before = await frameImage();
  await page.selectOption('#colormap', 'Jet');
  await settled();
  assert.notEqual(await frameImage(), before, 'the preset changed the image');
  const jet = await lastSent('tf.set');
  const range = jet.range;
  assert.equal(jet.colors.length, 7);
  assert.deepEqual(jet.colors[0], [range[0], 0, 0, 0.5625]);
  assert.equal(jet.colors.at(-1)[0], range[1]);
  // click the strip at 3/4 to add a colour point, then recolour it pure green
  await page.locator('#tf-editor').scrollIntoViewIfNeeded();  // below the vector and plane panels
  const box = await page.locator('#tf-editor').boundingBox();
  await page.mouse.click(box.x + box.width * 0.75, box.y + box.height - 4);
  await page.fill('#tf-color', '#00ff00');
  await settled();
  const edited = await lastSent('tf.set');
  assert.equal(edited.colors.length, 8, 'a colour point was added');
  assert.ok(edited.colors.some(([v, r, g, b]) => Math.abs(v - (range[0] + 0.75 * (range[1] - range[0]))) < (range[1] - range[0]) * 0.02 && r === 0 && g === 1 && b === 0), 'and recoloured green');
  assert.equal(await page.inputValue('#colormap'), 'custom');
  assert.match(page.url(), /colors=/, 'the edited colours are in the link');
  // right-click removes it again
  await page.mouse.click(box.x + box.width * 0.75, box.y + box.height - 4, { button: 'right' });
  await settled();
  assert.equal((await lastSent('tf.set')).colors.length, 7);
  await page.selectOption('#colormap', 'Cool to Warm');
  await settled();
  await shot('colormap');
});

test('the overall opacity and the unit distance scale the opacity sent', async () => {
  const base = (await lastSent('tf.set')).opacity;
  await page.locator('#opacity-scale').fill('50');
  await settled();
  const half = (await lastSent('tf.set')).opacity;
  half.forEach(([v, a], i) => assert.ok(Math.abs(a - base[i][1] / 2) < 1e-9, `point ${i}: ${a} is half ${base[i][1]}`));
  await page.locator('#opacity-scale').fill('100');
  // a unit distance twice the renderer's: the same extinction over twice the thickness
  const unit = await page.evaluate(() => {
    const b = window.tetrascope.dataset.bounds;
    return Math.hypot(...b.max.map((v, i) => v - b.min[i])) / 100;
  });
  await page.fill('#unit-distance', String(2 * unit));
  await page.locator('#unit-distance').dispatchEvent('change');
  await settled();
  const thinner = (await lastSent('tf.set')).opacity;
  thinner.forEach(([v, a], i) => assert.ok(Math.abs(a - (1 - Math.sqrt(1 - base[i][1]))) < 1e-9, `point ${i}: ${a}`));
  assert.match(page.url(), /unit=/);
  await page.fill('#unit-distance', '');
  await page.locator('#unit-distance').dispatchEvent('change');
  await settled();
});

test('keys and view buttons move the camera; the axes turn; ? lists the shortcuts', async () => {
  await page.locator('#frame').focus();
  const axesBefore = await page.evaluate(() => document.getElementById('axes').toDataURL());
  await page.keyboard.press('x');
  await settled();
  let camera = await page.evaluate(() => window.tetrascope.view.camera);
  let d = camera.target.map((t, i) => t - camera.eye[i]);
  assert.ok(d[0] > 0 && Math.abs(d[1]) < 1e-6 * Math.abs(d[0]) && Math.abs(d[2]) < 1e-6 * Math.abs(d[0]), `x looks along +X: ${d}`);
  assert.deepEqual(camera.up, [0, 0, 1]);
  const url = page.url();
  assert.notEqual(await page.evaluate(() => document.getElementById('axes').toDataURL()), axesBefore, 'the axes turned');
  await page.keyboard.press('Shift+Z');
  await settled();
  camera = await page.evaluate(() => window.tetrascope.view.camera);
  d = camera.target.map((t, i) => t - camera.eye[i]);
  assert.ok(d[2] < 0 && Math.abs(d[0]) < 1e-6 * Math.abs(d[2]), `shift+z looks along -Z: ${d}`);
  assert.notEqual(page.url(), url, 'the URL follows');
  const eye = camera.eye;
  await page.keyboard.press('ArrowLeft');
  await settled();
  assert.notDeepEqual((await page.evaluate(() => window.tetrascope.view.camera)).eye, eye, 'an arrow rotates');
  const distance = (c) => Math.hypot(...c.eye.map((e, i) => e - c.target[i]));
  const far = distance(await page.evaluate(() => window.tetrascope.view.camera));
  await page.keyboard.press('+');
  await settled();
  assert.ok(distance(await page.evaluate(() => window.tetrascope.view.camera)) < far, '+ zooms in');
  await page.click('button[data-view="iso"]');
  await settled();
  camera = await page.evaluate(() => window.tetrascope.view.camera);
  d = camera.target.map((t, i) => t - camera.eye[i]);
  assert.ok(Math.abs(d[0] - d[1]) < 1e-6 * Math.abs(d[0]) && Math.abs(d[1] - d[2]) < 1e-6 * Math.abs(d[0]), `isometric: ${d}`);
  await page.keyboard.press('p');
  await settled();
  const parallel = await lastSent('camera.set');
  assert.equal(parallel.orthographic, true, 'p: parallel projection');
  assert.ok(Math.abs(parallel.height - 2 * Math.hypot(...d) * Math.tan(Math.PI / 12)) < 1e-6 * parallel.height, 'showing what the perspective view showed at the target');
  assert.match(page.url(), /ortho=1/);
  assert.ok(await page.isChecked('#parallel'));
  await page.keyboard.press('p');
  await settled();
  assert.equal((await lastSent('camera.set')).orthographic, undefined);
  assert.ok(await page.isHidden('#help'));
  await page.keyboard.press('?');
  assert.ok(await page.isVisible('#help'), 'the shortcuts overlay appears');
  assert.match(await page.textContent('#help'), /isometric/);
  await page.keyboard.press('Escape');
  assert.ok(await page.isHidden('#help'));
  await page.keyboard.press('r');
  await settled();
  await shot('keys');
});

test('stream lines: turning them on changes the image; a click picks a line', async () => {
  await settled();
  const before = await frameImage();
  const fields = await page.$$eval('#lines-field option', (options) => options.map((o) => o.value));
  assert.deepEqual(fields, ['Velocity'], 'the vector fields of the dataset');
  await page.evaluate(() => (window.tetrascope.sent.length = 0));
  await page.check('#lines-on');
  await settled();
  const sent = await page.evaluate(() => window.tetrascope.sent);
  const lines = sent.find((m) => m.type === 'lines.set')?.body;
  assert.equal(lines?.field, 'Velocity');
  assert.equal(lines?.seeds, 'dense');
  assert.equal(sent.filter((m) => m.type === 'mode.set').at(-1)?.body.mode, 'dvr+lines');
  const withLines = await frameImage();
  assert.notEqual(withLines, before, 'the lines show in the image');
  await shot('lines');
  await page.check('#lines-pick');
  const box = await page.locator('#frame').boundingBox();
  await page.mouse.click(box.x + box.width / 2, box.y + box.height / 2);
  await settled();
  const pick = (await page.evaluate(() => window.tetrascope.sent)).filter((m) => m.type === 'lines.set').at(-1)?.body;
  assert.ok(Array.isArray(pick?.select?.pixel) && Math.abs(pick.select.pixel[0] - 0.5) < 0.05, 'the click is sent as a selection');
  await shot('lines-picked');
  await page.uncheck('#lines-pick');
  await page.uncheck('#lines-on');
  await settled();
  assert.equal(await frameImage(), before, 'without lines the image is as before');
});

test('a reconnect sends the whole view again (the mode stays)', async () => {
  await page.check('#mode-iso');
  await page.check('#box');
  await page.selectOption('#colormap', 'Inferno');
  await settled();
  const before = await canvasStats();
  const connects = await page.evaluate(() => window.tetrascope.connects);
  await page.evaluate(() => {
    window.tetrascope.sent.length = 0;  // from here: what the reconnect sends
    window.tetrascope.closeSocket();
  });
  await page.waitForFunction((n) => window.tetrascope.connects > n && window.tetrascope.stills > 0, connects, { timeout: 30000 });
  await page.waitForFunction(() => window.tetrascope.sent.some((m) => m.type === 'dataset.open'), null, { timeout: 30000 });
  await settled();
  const resent = await page.evaluate(() => window.tetrascope.sent);
  const mode = resent.filter((m) => m.type === 'mode.set').at(-1)?.body;
  // the box is the viewer's own overlay (overlays.js drawBox): the server is asked for none
  assert.deepEqual(mode, { mode: 'dvr+iso', wireframe: false, box: false }, 'the mode was sent again');
  assert.ok(await page.isChecked('#box'), 'the box stays on');
  assert.ok(resent.filter((m) => m.type === 'tf.set').at(-1).body.colors.length === 32, 'the colours were sent again');
  assert.ok(await page.isChecked('#mode-iso'));
  const after = await canvasStats();
  assert.ok(thumbDistance(before, after) < 2, `the image after the reconnect differs by ${thumbDistance(before, after).toFixed(2)} grey levels`);
  await shot('reconnected');
});

test('a link restores the same image in another page; copying it says so', async () => {
  await page.click('#copy-view');
  // the clipboard answers asynchronously: the feedback comes when it has
  await page.waitForFunction(() => document.getElementById('copy-feedback').textContent !== '', null, { timeout: 10000 });
  assert.match(await page.textContent('#copy-feedback'), /copied|copy/i, 'feedback after copying');
  const link = page.url();
  assert.match(link, /mode=dvr\+iso/);
  assert.match(link, /cmap=Inferno/);
  const original = await canvasStats();
  const other = await browser.newPage({ viewport: { width: 900, height: 560 } });
  try {
    await other.goto(link);
    await settled(other);
    assert.ok(await other.isChecked('#mode-iso'));
    assert.ok(await other.isChecked('#box'));
    assert.equal(await other.inputValue('#colormap'), 'Inferno');
    const copy = await canvasStats(other);
    assert.ok(thumbDistance(original, copy) < 2, `the linked page's image differs by ${thumbDistance(original, copy).toFixed(2)} grey levels`);
    assert.equal(new URL(other.url()).hash, new URL(link).hash, 'the same view');
  } finally {
    await other.close();
  }
  await page.uncheck('#mode-iso');
  await page.uncheck('#box');
  await settled();
});

test('a link to a dataset that is gone opens the first one', async () => {
  const other = await browser.newPage({ viewport: { width: 600, height: 400 } });
  try {
    await other.goto(`${url}#dataset=no-such-dataset&mode=dvr+surface`);
    await other.waitForFunction(() => window.tetrascope.dataset?.name === 'disk', null, { timeout: 30000 });
    await settled(other);
    assert.ok(await other.isChecked('#mode-surface'), 'the rest of the link still applies');
    assert.match(other.url(), /dataset=disk/);
    // a hand-written link: no attribute (the first), a range
    await other.goto(`${url}?again#dataset=disk&range=0.1,0.17`);
    await other.waitForFunction(() => window.tetrascope.dataset?.name === 'disk', null, { timeout: 30000 });
    await settled(other);
    assert.deepEqual(await lastSent('tf.set', other).then((b) => b.range), [0.1, 0.17]);
    assert.equal(await other.inputValue('#range-min'), '0.1');
  } finally {
    await other.close();
  }
});

test('a page that cannot load the dataset list says so, not "no dataset", and opens one once the list comes', async () => {
  const other = await browser.newPage({ viewport: { width: 600, height: 400 } });
  try {
    await other.route('**/api/v1/datasets', (route) => route.abort('connectionreset'));
    await other.goto(url);
    await other.waitForFunction(() => /could not be loaded/.test(document.getElementById('dataset-summary').textContent), null, { timeout: 30000 });
    assert.doesNotMatch(await other.textContent('#dataset-summary'), /No dataset yet/);
    assert.ok(!(await other.evaluate(() => window.tetrascope.dataset)), 'nothing opened without a list');
    await other.unroute('**/api/v1/datasets');
    await other.waitForFunction(() => window.tetrascope.dataset?.name === 'disk', null, { timeout: 30000 });
    await settled(other);
    assert.doesNotMatch(await other.textContent('#dataset-summary'), /could not be loaded/);
  } finally {
    await other.close();
  }
});

test('Save image: a still at the chosen size with the legend, dataset and attribute', async () => {
  await page.selectOption('#save-size', '1280x720');
  const [download] = await Promise.all([page.waitForEvent('download', { timeout: 60000 }), page.click('#save-image')]);
  const path = await download.path();
  const bytes = readFileSync(path);
  assert.deepEqual([...bytes.subarray(1, 4)].map((b) => String.fromCharCode(b)).join(''), 'PNG');
  assert.deepEqual(pngSize(bytes), [1280, 720]);
  assert.match(download.suggestedFilename(), /^disk-.+\.png$/);
  assert.match(await page.textContent('#save-status'), /1280×720/);
  await settled();  // the view is back at its own size
  assert.equal(await page.evaluate(() => window.tetrascope.lastStill.header.width), await page.evaluate(() => document.getElementById('frame').width));
  // the legend is composited in the lower left; the upper right is the still as it was
  const regions = await page.evaluate(async () => {
    const composed = await createImageBitmap(await window.tetrascope.composeStill());
    const raw = await createImageBitmap(window.tetrascope.lastStill.blob);
    const diff = (x, y, w, h) => {
      const pixels = (bitmap) => {
        const c = new OffscreenCanvas(bitmap.width, bitmap.height), g = c.getContext('2d');
        g.drawImage(bitmap, 0, 0);
        return g.getImageData(x, y, w, h).data;
      };
      const a = pixels(composed), b = pixels(raw);
      let sum = 0;
      for (let i = 0; i < a.length; ++i) sum += Math.abs(a[i] - b[i]);
      return sum / a.length;
    };
    return { legend: diff(30, raw.height - 58, 160, 8), corner: diff(raw.width - 100, 0, 100, 60) };  // the bar; a corner
  });
  assert.ok(regions.legend > 20, `the legend region changed by ${regions.legend}`);
  assert.ok(regions.corner < 1, `the corner changed by ${regions.corner}`);
  await page.selectOption('#save-size', 'view');
});

test('on a 390x844 phone the panel collapses and the view takes the width', async () => {
  const wide = await page.evaluate(() => [document.getElementById('panel').getBoundingClientRect().width, document.getElementById('panel-toggle').offsetParent === null]);
  assert.deepEqual(wide, [290, true], 'wide screens keep the 290 px panel and no toggle');
  const phone = await browser.newPage({ viewport: { width: 390, height: 844 }, isMobile: true, hasTouch: true });
  try {
    await phone.goto(url);
    await settled(phone);
    const frame = await phone.locator('#frame').boundingBox();
    assert.ok(frame.width >= 0.6 * 390, `the view is ${frame.width} px wide`);
    const drawer = await phone.locator('#panel').boundingBox();
    assert.ok(!(await phone.locator('#panel').isVisible()) || drawer.x + drawer.width <= 0, 'the panel is out of the way');
    await phone.click('#panel-toggle');
    await phone.waitForFunction(() => document.getElementById('panel').getBoundingClientRect().left >= 0);
    assert.equal(await phone.getAttribute('#panel-toggle', 'aria-expanded'), 'true');
    await phone.selectOption('#colormap', 'Viridis');  // the controls work in the drawer
    await settled(phone);
    await shot('phone-panel', phone);
    await phone.click('#panel-toggle');
    await phone.waitForFunction(() => document.getElementById('panel').getBoundingClientRect().right <= 0);
    await shot('phone', phone);
  } finally {
    await phone.close();
  }
});

test('a taken dataset name is refused before anything is uploaded', async () => {
  await page.setInputFiles('#upload-file', sample);
  await page.fill('#job-name', 'disk');
  await page.click('#upload-submit');
  await page.waitForFunction(() => /exists/.test(document.getElementById('job-status').textContent));
  const uploads = await page.evaluate(() => fetch('/api/v1/uploads').then((r) => r.json()));
  assert.deepEqual(uploads.uploads, [], 'nothing was uploaded');
});

test('a failed job shows its error in the jobs panel, not repeated by the log tail', async () => {
  const broken = join(data, 'broken.vtk');
  writeFileSync(broken, '# vtk DataFile Version 3.0\nbroken\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 3 float\n0 0 0\n');
  await page.setInputFiles('#upload-file', broken);
  await page.fill('#job-name', 'broken-mesh');
  await page.click('#upload-submit');
  await page.waitForFunction(() => /broken-mesh: failed/.test(document.getElementById('job-status').textContent), null, { timeout: 60000 });
  await page.waitForFunction(() => document.querySelector('#jobs li[data-state="failed"]')?.textContent.includes('broken-mesh'), null, { timeout: 30000 });
  const failed = page.locator('#jobs li[data-state="failed"]').first();
  assert.ok(await failed.locator('summary').textContent(), 'the error');
  await failed.locator('summary').click();
  // the log tail shows the lines the error does not hold: here none (its one line is the error)
  assert.equal(await failed.locator('pre').count(), 0, 'no log tail repeating the error');
});

test('upload and preprocess: the job survives a reload, reaches 100% and the dataset opens', async () => {
  await page.setInputFiles('#upload-file', sample);
  await page.fill('#job-name', 'uploaded-disk');
  await page.click('#upload-submit');
  await page.waitForFunction(() => /uploaded-disk: (queued|running|done)/.test(document.getElementById('job-status').textContent), null, { timeout: 60000 });
  await page.reload();
  // after the reload: the job is listed and followed again
  await page.waitForFunction(() => document.querySelector('#jobs li[data-job]')?.textContent.includes('uploaded-disk'), null, { timeout: 30000 });
  await page.waitForFunction(() => /uploaded-disk/.test(document.getElementById('job-status').textContent), null, { timeout: 30000 });
  await page.waitForFunction(() => document.getElementById('job-progress').value === 100, null, { timeout: 120000 });
  assert.match(await page.textContent('#job-status'), /done/);
  await page.waitForFunction(() => window.tetrascope.dataset?.name === 'uploaded-disk', null, { timeout: 30000 });
  const options = await page.$$eval('#dataset option', (o) => o.map((x) => x.value));
  assert.ok(options.includes('uploaded-disk'));
  await page.waitForFunction(() => document.querySelector('#jobs li[data-state="done"]')?.textContent.includes('uploaded-disk'), null, { timeout: 30000 });
  await shot('uploaded');
});

test('a dataset can be deleted from the list: the viewer opens another, and another viewer of it is told, even one that cannot load the list', async () => {
  const other = await browser.newPage({ viewport: { width: 600, height: 400 } });
  try {
    await other.goto(url);
    await settled(other);
    await other.selectOption('#dataset', 'uploaded-disk');
    await other.waitForFunction(() => window.tetrascope.dataset?.name === 'uploaded-disk', null, { timeout: 30000 });
    await page.selectOption('#dataset', 'uploaded-disk');
    await page.waitForFunction(() => window.tetrascope.dataset?.name === 'uploaded-disk', null, { timeout: 30000 });
    // asked first: a "no" deletes nothing
    page.once('dialog', (dialog) => dialog.dismiss());
    await page.click('#dataset-delete');
    await page.waitForTimeout(300);
    assert.ok(existsSync(join(data, 'uploaded-disk', 'manifest.json')), 'kept after a "no"');
    // the other viewer cannot load the list after the deletion (a server too busy to answer):
    // it works from the list it had, less the dataset deleted
    await other.route('**/api/v1/datasets', (route) => route.abort('connectionreset'));
    page.once('dialog', (dialog) => dialog.accept());
    await page.click('#dataset-delete');
    // this viewer and the other one move to the dataset left, and say why
    for (const p of [page, other]) {
      try {
        await p.waitForFunction(() => window.tetrascope.dataset?.name === 'disk', null, { timeout: 30000 });
      } catch (error) {  // what the page shows and what its client recorded, for the log
        const seen = await p.evaluate(() => ({ summary: document.getElementById('dataset-summary').textContent, errors: window.tetrascope.errors, sent: window.tetrascope.sent.slice(-3).map((m) => m.type), received: window.tetrascope.received.slice(-6), connected: window.tetrascope.connected, closes: window.tetrascope.closes, now: Math.round(performance.now()), banner: document.getElementById('banner').textContent, options: [...document.getElementById('dataset').options].map((o) => o.value) }));
        throw new Error(`${error.message}\n${p === page ? 'the deleting page' : 'the other page'}: ${JSON.stringify(seen)}`);
      }
      const listErrors = await p.evaluate(() => window.tetrascope.errors.filter((e) => e.code === 'dataset_list'));
      if (p === other) assert.ok(listErrors.length >= 1, 'the other viewer worked from the list it had');
      else if (listErrors.length) console.log(`# the dataset list failed after the deletion: ${JSON.stringify(listErrors)}`);
      assert.match(await p.textContent('#dataset-summary'), /uploaded-disk' was deleted/);
      const options = await p.$$eval('#dataset option', (o) => o.map((x) => x.value));
      assert.ok(!options.includes('uploaded-disk'), `still listed: ${options}`);
    }
    await other.unroute('**/api/v1/datasets');
    await settled(other);
    await shot('deleted', other);
    assert.ok(!existsSync(join(data, 'uploaded-disk')), 'the store is gone');
    assert.deepEqual(readdirSync(data).filter((f) => f.startsWith('.trash-')), [], 'nothing left aside');
  } finally {
    await other.close();
  }
});
