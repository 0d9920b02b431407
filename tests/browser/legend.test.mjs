// Legends and overlays readable in saved images, in headless Chromium: the legend's min/max
// labels are drawn in an ink chosen from what lies under them, not in the colormap's last
// colour (X Ray ends in black, Turbo in dark red: both vanished on the dark legend box), and
// the bounding box is drawn in a colour that stands out from the renderer's dark background,
// on the screen and in the saved image. Measured on the pixels of the composited still.
//   node --test tests/browser/legend.test.mjs   (TETRA_BINARY: the tetrascope executable)
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { startViewer, settled as settledOn } from './harness.mjs';
import { boxCorners, project } from './projection.mjs';

let viewer, page;

before(async () => {
  viewer = await startViewer({ prefix: 'tetrascope-legend-', viewport: { width: 900, height: 560 } });
  page = viewer.page;
  await page.goto(viewer.url);
  await settled();
});

after(async () => {
  await viewer?.stop();
});

const settled = () => settledOn(page, 0);

// The still as Save image composites it, as {width, height, pixels (RGBA)}, in the page.
const composedStill = () =>
  page.evaluate(async () => {
    const bitmap = await createImageBitmap(await window.tetrascope.composeStill());
    const c = new OffscreenCanvas(bitmap.width, bitmap.height), g = c.getContext('2d');
    g.drawImage(bitmap, 0, 0);
    return { width: bitmap.width, height: bitmap.height, pixels: [...g.getImageData(0, 0, bitmap.width, bitmap.height).data] };
  });

const luminance = (image, x, y) => {
  const i = 4 * (Math.round(y) * image.width + Math.round(x));
  return 0.2126 * image.pixels[i] + 0.7152 * image.pixels[i + 1] + 0.0722 * image.pixels[i + 2];
};

// Pixels of a rectangle that stand out from its median luminance by more than `by` grey levels:
// the strokes of text drawn in a readable ink.
function strokes(image, x0, y0, w, h, by) {
  const values = [];
  for (let y = y0; y < y0 + h; ++y) for (let x = x0; x < x0 + w; ++x) values.push(luminance(image, x, y));
  const median = [...values].sort((a, b) => a - b)[values.length >> 1];
  return values.filter((v) => Math.abs(v - median) > by).length;
}

test('the legend\'s min and max labels are readable whatever the colormap', async () => {
  for (const preset of ['X Ray', 'Turbo', 'Cool to Warm']) {
    await page.selectOption('#colormap', preset);
    await settled();
    const image = await composedStill();
    // the legend's layout (overlays.js composeStill): at scale s, padding 10s, a 14s bar and
    // 12s text; the labels are the line under the bar, min on the left, max on the right
    const s = Math.max(1, Math.min(image.width, image.height) / 600);
    const pad = 10 * s, font = Math.round(12 * s), barHeight = Math.round(14 * s), barWidth = Math.round(220 * s);
    const boxHeight = barHeight + 3 * font + 3 * pad, y0 = image.height - boxHeight - pad;
    const labelTop = Math.round(y0 + 2 * pad + font + barHeight + pad / 2);
    const min = strokes(image, Math.round(2 * pad), labelTop, Math.round(50 * s), font, 100);
    const max = strokes(image, Math.round(2 * pad + barWidth - 50 * s), labelTop, Math.round(50 * s), font, 100);
    assert.ok(min >= 10 && max >= 10, `${preset}: the min label has ${min} and the max label ${max} pixels 100 grey levels off their background`);
  }
  await page.click('#tf-reset');
  await settled();
});

test('the bounding box stands out from the background, on the screen and in the saved image', async () => {
  // the volume made transparent: the box is all there is on the background
  await page.evaluate(() => {
    const slider = document.getElementById('opacity-scale');
    slider.value = '0';
    slider.dispatchEvent(new Event('input'));
  });
  await page.check('#box');
  await settled();
  const view = await page.evaluate(() => ({ camera: window.tetrascope.lastStill.camera ?? window.tetrascope.view.camera, bounds: window.tetrascope.dataset.bounds }));
  const image = await composedStill();
  const screen = await page.evaluate(() => {
    const frame = document.getElementById('frame'), overlay = document.getElementById('box-overlay');
    const c = new OffscreenCanvas(frame.width, frame.height), g = c.getContext('2d');
    g.drawImage(frame, 0, 0);
    if (overlay) g.drawImage(overlay, 0, 0);
    return { width: c.width, height: c.height, pixels: [...g.getImageData(0, 0, c.width, c.height).data] };
  });
  const background = luminance(image, 2, 2);
  // samples along the 12 edges (the middle 80% of each), inside the image and clear of the legend
  const corners = boxCorners(view.bounds);
  const edges = [[0, 1], [2, 3], [4, 5], [6, 7], [0, 2], [1, 3], [4, 6], [5, 7], [0, 4], [1, 5], [2, 6], [3, 7]];
  for (const [name, picture] of [['saved image', image], ['screen', screen]]) {
    let seen = 0, total = 0;
    for (const [a, b] of edges)
      for (let t = 0.1; t <= 0.9; t += 0.1) {
        const p = corners[a].map((v, k) => v + t * (corners[b][k] - v));
        const [x, y] = project(view.camera, picture.width, picture.height, p);
        if (x < 3 || y < 3 || x > picture.width - 4 || y > picture.height - 4 || (x < 260 && y > picture.height - 90)) continue;
        total += 1;
        let contrast = 0;  // the most the 5x5 pixels around the sample differ from the background
        for (let dy = -2; dy <= 2; ++dy) for (let dx = -2; dx <= 2; ++dx) contrast = Math.max(contrast, Math.abs(luminance(picture, x + dx, y + dy) - background));
        if (contrast > 60) seen += 1;
      }
    assert.ok(total >= 40, `${name}: ${total} samples on the box's edges`);
    assert.ok(seen >= 0.9 * total, `${name}: ${seen} of ${total} samples on the box's edges stand 60 grey levels off the background`);
  }
  await page.uncheck('#box');
  await page.click('#tf-reset');
  await settled();
});
