// Legends and overlays readable in saved images, in headless Chromium: the legend's min/max
// labels are drawn in an ink chosen from what lies under them, not in the colormap's last
// colour (X Ray ends in black, Turbo in dark red: both vanished on the dark legend box), and
// the bounding box is drawn in a colour that stands out from the renderer's dark background,
// on the screen and in the saved image. One legend per coloured thing (the attribute's, the
// stream lines' over their field's range), with ticks and a title edited in place; invert and
// a log scale of the colours. Measured on the pixels of the composited still.
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

// The composited legends' layout (overlays.js composeStill): side by side from the lower left,
// each 220s + 20s wide; the labels' line under the bar.
const legendLayout = (image, index) => {
  const s = Math.max(1, Math.min(image.width, image.height) / 600);
  const pad = 10 * s, font = Math.round(12 * s), barHeight = Math.round(14 * s), barWidth = Math.round(220 * s);
  const boxHeight = barHeight + 3 * font + 3 * pad, x0 = pad + index * (barWidth + 3 * pad), y0 = image.height - boxHeight - pad;
  return { s, pad, font, barWidth, x0, y0, titleTop: Math.round(y0 + pad), labelTop: Math.round(y0 + 2 * pad + font + barHeight + pad / 2) };
};
const legendKeys = () => page.evaluate(() => [...document.querySelectorAll('#legend .legend')].map((l) => l.dataset.key));
const lastTf = () => page.evaluate(() => window.tetrascope.sent.filter((m) => m.type === 'tf.set').at(-1).body);

test('one legend per coloured thing: the attribute\'s, and the stream lines\' over their field\'s range', async () => {
  assert.deepEqual(await legendKeys(), ['attribute']);
  assert.equal(await page.textContent('#legend .legend[data-key=attribute] .legend-caption'), 'volume');
  const ticks = await page.locator('#legend .legend[data-key=attribute] .legend-ticks span').count();
  assert.ok(ticks >= 3, `the bar has ${ticks} labelled ticks (the ends and round values between)`);
  await page.check('#lines-on');
  await settled();
  assert.deepEqual(await legendKeys(), ['attribute', 'lines']);
  // the lines are coloured over their field's magnitude range over the dataset: the legend says which
  const { labels, expected } = await page.evaluate(() => {
    const field = window.tetrascope.dataset.attributes.find((a) => a.components === 3);
    const fmt = (v) => (Math.abs(v) >= 1e5 || (Math.abs(v) < 1e-3 && v !== 0) ? v.toExponential(2) : String(+v.toPrecision(4)));
    const spans = [...document.querySelectorAll('#legend .legend[data-key=lines] .legend-ticks span')];
    return { labels: [spans[0].textContent, spans.at(-1).textContent], expected: [fmt(field.range[0]), fmt(field.range[1])] };
  });
  assert.deepEqual(labels, expected);
  const image = await composedStill();
  for (const index of [0, 1]) {
    const { pad, font, barWidth, x0, labelTop, s } = legendLayout(image, index);
    const min = strokes(image, Math.round(x0 + pad), labelTop, Math.round(50 * s), font, 100);
    const max = strokes(image, Math.round(x0 + pad + barWidth - 50 * s), labelTop, Math.round(50 * s), font, 100);
    assert.ok(min >= 10 && max >= 10, `legend ${index} in the saved image: labels of ${min} and ${max} pixels 100 grey levels off their background`);
  }
  // the volume off, nothing else coloured by the attribute: the lines' legend alone
  await page.uncheck('#mode-dvr');
  await settled();
  assert.deepEqual(await legendKeys(), ['lines']);
  await page.check('#mode-dvr');
  await page.uncheck('#lines-on');
  await settled();
  assert.deepEqual(await legendKeys(), ['attribute']);
});

test('a legend\'s title is edited in place, kept in the link and drawn in the saved image', async () => {
  const before = await composedStill();
  const title = page.locator('#legend .legend[data-key=attribute] .legend-title');
  await title.click();
  await page.keyboard.press('Control+A');
  await page.keyboard.type('Pressure (Pa)');
  await page.keyboard.press('Enter');
  assert.equal(await page.evaluate(() => window.tetrascope.view.legendTitles.attribute), 'Pressure (Pa)');
  assert.match(page.url(), /title\.attribute=Pressure%20\(Pa\)/);
  const after = await composedStill();
  const { x0, pad, titleTop, font, barWidth } = legendLayout(after, 0);
  let differ = 0;
  for (let y = titleTop; y < titleTop + font; ++y) for (let x = Math.round(x0 + pad); x < x0 + pad + barWidth; ++x) if (Math.abs(luminance(after, x, y) - luminance(before, x, y)) > 60) differ += 1;
  assert.ok(differ > 20, `the title's line changed in ${differ} pixels`);
  await page.reload();
  await settled();
  assert.equal(await title.textContent(), 'Pressure (Pa)', 'the link keeps the title');
  // emptied: the default again
  await title.click();
  await page.keyboard.press('Control+A');
  await page.keyboard.press('Delete');
  await page.keyboard.press('Enter');
  assert.doesNotMatch(page.url(), /title\.attribute/);
  assert.notEqual(await title.textContent(), '');
});

test('invert mirrors the colours; a log scale sends colours evenly in log10 and labels powers of ten', async () => {
  const before = await lastTf();
  await page.click('#tf-invert');
  await settled();
  const inverted = await lastTf();
  assert.deepEqual(inverted.colors[0].slice(1), before.colors.at(-1).slice(1), 'the first colour is the last one before');
  assert.deepEqual(inverted.colors.at(-1).slice(1), before.colors[0].slice(1));
  await page.click('#tf-reset');
  // a range above 0 (the log scale is disabled while it reaches 0)
  const hi = before.range[1] > 0 ? before.range[1] : 1;
  await page.fill('#range-min', String(hi / 1000));
  await page.fill('#range-max', String(hi));
  await page.locator('#range-max').dispatchEvent('change');
  assert.equal(await page.isDisabled('#log-scale'), false);
  await page.check('#log-scale');
  await settled();
  const log = await lastTf();
  assert.equal(log.colors.length, 64);
  const ratios = log.colors.slice(1).map((c, i) => c[0] / log.colors[i][0]);
  assert.ok(ratios.every((r) => Math.abs(r / ratios[0] - 1) < 1e-6), 'colour points evenly spaced in log10');
  assert.match(await page.textContent('#legend .legend[data-key=attribute] .legend-caption'), /log scale/);
  const middle = await page.evaluate(() => [...document.querySelectorAll('#legend .legend[data-key=attribute] .legend-ticks span[data-align=middle]')].map((s) => Number(s.textContent)));
  const mantissa = (v) => v / 10 ** Math.floor(Math.log10(v) + 1e-9);
  assert.ok(middle.length >= 1 && middle.every((v) => [1, 2, 5].some((m) => Math.abs(mantissa(v) - m) < 1e-3)), `ticks at 1, 2 or 5 times a power of ten: ${middle}`);
  await page.uncheck('#log-scale');
  await page.click('#range-reset');
  await page.click('#tf-reset');
  await settled();
});

test('a white background: the image\'s, in the link, with the legend still readable in the saved image', async () => {
  await page.locator('#background').evaluate((input) => {
    input.value = '#ffffff';
    input.dispatchEvent(new Event('change'));
  });
  await settled();
  assert.deepEqual((await page.evaluate(() => window.tetrascope.sent.filter((m) => m.type === 'mode.set').at(-1).body)).background, [1, 1, 1]);
  assert.match(page.url(), /bg=ffffff/);
  const image = await composedStill();
  assert.ok(luminance(image, image.width - 3, 3) > 240, `the image's corner is white: ${luminance(image, image.width - 3, 3)}`);
  const { pad, font, barWidth, x0, labelTop, s } = legendLayout(image, 0);
  const min = strokes(image, Math.round(x0 + pad), labelTop, Math.round(50 * s), font, 100);
  const max = strokes(image, Math.round(x0 + pad + barWidth - 50 * s), labelTop, Math.round(50 * s), font, 100);
  assert.ok(min >= 10 && max >= 10, `on white, labels of ${min} and ${max} pixels 100 grey levels off their background`);
  await page.click('#background-reset');
  await settled();
  assert.doesNotMatch(page.url(), /bg=/);
  assert.ok(luminance(await composedStill(), image.width - 3, 3) < 60, 'the dark default again');
});

test('isosurfaces coloured by another attribute get a legend of their own over its range', async () => {
  await page.uncheck('#mode-dvr');
  await page.check('#mode-iso');
  await settled();
  assert.deepEqual(await legendKeys(), ['attribute']);
  assert.equal(await page.textContent('#legend .legend[data-key=attribute] .legend-caption'), 'isosurface');
  const other = await page.evaluate(() => window.tetrascope.dataset.attributes.find((a) => a.name !== window.tetrascope.view.attribute && a.components === 1));
  const byValue = await page.evaluate(() => document.getElementById('frame').toDataURL());
  await page.selectOption('#iso-color-by', other.name);
  await settled();
  assert.equal((await page.evaluate(() => window.tetrascope.sent.filter((m) => m.type === 'iso.set').at(-1).body)).color_by, other.name);
  assert.match(page.url(), new RegExp(`isocolor=${other.name}`));
  assert.notEqual(await page.evaluate(() => document.getElementById('frame').toDataURL()), byValue, 'the isosurfaces took other colours');
  assert.deepEqual(await legendKeys(), ['iso'], 'nothing else is coloured by the attribute now');
  const labels = await page.evaluate(() => [...document.querySelectorAll('#legend .legend[data-key=iso] .legend-ticks span')].map((s) => s.textContent));
  const fmt = (v) => (Math.abs(v) >= 1e5 || (Math.abs(v) < 1e-3 && v !== 0) ? v.toExponential(2) : String(+v.toPrecision(4)));
  assert.deepEqual([labels[0], labels.at(-1)], [fmt(other.range[0]), fmt(other.range[1])]);
  await page.selectOption('#iso-color-by', '');
  await page.uncheck('#mode-iso');
  await page.check('#mode-dvr');
  await settled();
  assert.deepEqual(await legendKeys(), ['attribute']);
});

test('a vector coloured by one component: a selector beside the attribute, the legend\'s title and range, the link and the image', async () => {
  const scalar = await page.evaluate(() => window.tetrascope.view.attribute);
  assert.equal(await page.isHidden('#component-row'), true, 'a scalar has no component to choose');
  const vector = await page.evaluate(() => window.tetrascope.dataset.attributes.find((a) => a.components === 3));
  assert.equal(vector.component_ranges.length, 3, 'dataset.info gives the components\' ranges');
  await page.selectOption('#attribute', vector.name);
  await settled();
  assert.equal(await page.isVisible('#component-row'), true);
  assert.deepEqual(await page.$$eval('#component option', (options) => options.map((o) => o.textContent)), ['Magnitude', 'X', 'Y', 'Z']);
  const title = page.locator('#legend .legend[data-key=attribute] .legend-title');
  assert.equal(await title.textContent(), `disk — ${vector.name} Magnitude`);
  assert.equal((await lastTf()).component, undefined, 'the magnitude is sent as no component');
  const magnitude = await page.evaluate(() => document.getElementById('frame').toDataURL());
  await page.selectOption('#component', 'x');
  await settled();
  assert.equal(await title.textContent(), `disk — ${vector.name} X`);
  const sent = await lastTf();
  assert.equal(sent.component, 'x');
  assert.deepEqual(sent.range, vector.component_ranges[0], 'the colour range is the X component\'s over the dataset');
  assert.notDeepEqual(vector.component_ranges[0], vector.range);
  const fmt = (v) => (Math.abs(v) >= 1e5 || (Math.abs(v) < 1e-3 && v !== 0) ? v.toExponential(2) : String(+v.toPrecision(4)));
  const labels = await page.evaluate(() => [...document.querySelectorAll('#legend .legend[data-key=attribute] .legend-ticks span')].map((s) => s.textContent));
  assert.deepEqual([labels[0], labels.at(-1)], vector.component_ranges[0].map(fmt));
  assert.notEqual(await page.evaluate(() => document.getElementById('frame').toDataURL()), magnitude, 'the X component drew another image');
  assert.match(page.url(), /component=x/);
  assert.deepEqual(await page.evaluate(() => window.tetrascope.errors), []);
  await page.reload();
  await settled();
  assert.equal(await page.inputValue('#component'), 'x', 'the link keeps the component');
  assert.equal(await title.textContent(), `disk — ${vector.name} X`);
  await page.selectOption('#attribute', scalar);
  await settled();
  assert.equal(await page.isHidden('#component-row'), true);
  assert.equal((await lastTf()).component, undefined);
  assert.doesNotMatch(page.url(), /component=/);
});
