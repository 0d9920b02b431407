// The viewer's state <-> URL codec and the transfer function it sends (no browser):
// a round trip keeps every field, a hostile fragment leaves the defaults, and the opacity
// scale, unit distance and "transparent outside the range" transform the points as documented.
//   node --test tests/browser/view-state.test.mjs
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { colorAt, PRESETS } from '../../web-client/colormaps.js';
import { componentsOf, defaultView, drawnName, rangeOfDrawn, rebin, sentAlpha, tfBody, viewFromHash, viewToHash } from '../../web-client/view-state.js';
import { visibleCorners } from '../../web-client/visible.js';
import { OrbitCamera } from '../../web-client/camera.js';

const full = () => ({
  ...defaultView(),
  dataset: 'disk', attribute: 'Temp', camera: { eye: [1, 2, 3.5], target: [0, -1, 0], up: [0, 0, 1], fov: 40 },
  preset: 'Viridis', colors: [[0, 1, 0, 0], [0.25, 0, 1, 0], [1, 0, 0, 1]], customColors: true,
  opacity: [[0, 0.1], [0.3, 0.5], [1, 0.2]], range: [300, 900], opacityScale: 0.5, unitDistance: 0.25,
  outsideTransparent: true, dvr: false, iso: true, surface: true, wireframe: true, box: true,
  isovalues: [400, 500.5], isoOpacity: 0.4, budget: 50000, interactionBudget: 20000,
  interactionQuality: 40, stillQuality: 95, pngStills: true, hiddenRegions: [0, 2, 17],
});

test('a view survives the URL fragment whole', () => {
  const view = full();
  assert.deepEqual(viewFromHash(`#${viewToHash(view)}`), view);
  assert.deepEqual(viewFromHash(`#${viewToHash(defaultView())}`), defaultView());
});

test('one component of a vector: kept in the link, sent in tf.set, named and ranged as drawn', () => {
  const view = { ...full(), attribute: 'Velocity', component: 'y', range: [-2, 3] };
  assert.deepEqual(viewFromHash(`#${viewToHash(view)}`), view);
  assert.equal(tfBody(view, 1).component, 'y');
  assert.equal('component' in tfBody(full(), 1), false, 'the magnitude (or a scalar) is sent as no component');
  assert.equal(viewFromHash('#component=w').component, 'magnitude', 'an unknown component is dropped');
  const velocity = { name: 'Velocity', components: 3, range: [0, 5], component_ranges: [[-4, 4], [-1, 2], [3, 3]] };
  assert.deepEqual(componentsOf(velocity), ['magnitude', 'x', 'y', 'z']);
  assert.deepEqual(componentsOf({ name: 'Temp', components: 1, range: [0, 1] }), []);
  assert.equal(drawnName(velocity, 'x'), 'Velocity X');
  assert.equal(drawnName(velocity, 'magnitude'), 'Velocity Magnitude');
  assert.equal(drawnName({ name: 'Temp', components: 1 }, 'x'), 'Temp');
  assert.deepEqual(rangeOfDrawn(velocity, 'y'), [-1, 2]);
  assert.deepEqual(rangeOfDrawn(velocity, 'z'), [3, 4], 'never an empty range');
  assert.deepEqual(rangeOfDrawn(velocity, 'magnitude'), [0, 5]);
});

test('a hostile or broken fragment leaves the defaults', () => {
  for (const hash of ['#', '#%', '#dataset=../etc&range=5,1&opacity=0:2,x:1&colors=0:zzzzzz,1:000000&eye=1,2&iso=a,b&budget=-3&cmap=nope&unit=-1&oscale=NaN',
    `#opacity=${Array.from({ length: 100 }, (_, i) => `${i / 99}:0.5`).join(',')}`, '#opacity=1:0,0:1']) {
    const view = viewFromHash(hash);
    assert.equal(view.dataset, null, hash);
    assert.deepEqual(view.opacity, defaultView().opacity, hash);
    assert.deepEqual(view.colors, defaultView().colors, hash);
    assert.equal(view.range, null, hash);
    assert.equal(view.camera, null, hash);
    assert.deepEqual(view.isovalues, [], hash);
    assert.equal(view.budget, null, hash);
    assert.equal(view.unitDistance, null, hash);
    assert.equal(view.opacityScale, 1, hash);
  }
});

test('hidden regions from a link: whole ids below the limit, once each, in order', () => {
  assert.deepEqual(viewFromHash('#hide=5,x,1,-2,99999,1024,1023,5,1.5,2').hiddenRegions, [1, 2, 5, 1023]);
  assert.deepEqual(viewFromHash('#hide=').hiddenRegions, []);
  assert.deepEqual(viewFromHash(`#hide=${Array.from({ length: 5000 }, (_, i) => i).join(',')}`).hiddenRegions.length, 1024);
});

test('the opacity sent: scaled, then the unit distance as equal extinction', () => {
  const view = { ...defaultView(), opacityScale: 2, unitDistance: 2 };
  // 0.2 -> 0.4 -> 1 - 0.6^(1/2)
  assert.ok(Math.abs(sentAlpha(0.2, view, 1) - (1 - Math.sqrt(0.6))) < 1e-12);
  assert.equal(sentAlpha(0.7, view, 1), 1);
  assert.equal(sentAlpha(0.3, defaultView(), 1), 0.3);
});

test('tf.set maps points onto the range; transparent outside it makes the ends zero', () => {
  const view = { ...full(), opacityScale: 1, unitDistance: null, outsideTransparent: false };
  const body = tfBody(view, 1);
  assert.deepEqual(body.range, [300, 900]);
  assert.deepEqual(body.opacity, [[300, 0.1], [480, 0.5], [900, 0.2]]);
  assert.deepEqual(body.colors[1], [450, 0, 1, 0]);
  const transparent = tfBody({ ...view, outsideTransparent: true }, 1);
  assert.deepEqual(transparent.opacity[0], [300, 0]);
  assert.deepEqual(transparent.opacity.at(-1), [900, 0]);
  assert.ok(transparent.opacity.every(([v], i, a) => !i || v >= a[i - 1][0]), 'values ascend');
  assert.ok(Math.abs(transparent.opacity[1][0] - 300.6) < 1e-9);
});

test('every preset is a valid colour table from 0 to 1', () => {
  for (const [name, points] of Object.entries(PRESETS)) {
    assert.equal(points[0][0], 0, name);
    assert.equal(points.at(-1)[0], 1, name);
    assert.ok(points.length >= 2 && points.length <= 64, name);
    points.forEach((p, i) => {
      assert.equal(p.length, 4, name);
      assert.ok(p.slice(1).every((c) => c >= 0 && c <= 1), `${name}[${i}]`);
      if (i) assert.ok(p[0] > points[i - 1][0], `${name}[${i}] ascends`);
    });
  }
  // published anchors: Moreland's cool-warm midpoint, matplotlib's ends (#440154, #fde725 for
  // viridis, #fcffa4 for inferno; the polynomial fits are within a few levels)
  const near = (rgb, hex) => rgb.every((c, k) => Math.abs(c * 255 - parseInt(hex.slice(2 * k, 2 * k + 2), 16)) <= 5);
  assert.ok(colorAt(PRESETS['Cool to Warm'], 0.5).every((c) => Math.abs(c - 0.865) < 0.01));
  assert.ok(near(PRESETS.Viridis[0].slice(1), '440154'));
  assert.ok(near(PRESETS.Viridis.at(-1).slice(1), 'fde725'));
  assert.ok(near(PRESETS.Inferno.at(-1).slice(1), 'fcffa4'));
});

test('re-binning a histogram onto a narrower range spreads each bin over its span', () => {
  assert.deepEqual(rebin([4, 8], [0, 2], [0, 2], 4), [2, 2, 4, 4]);
  assert.deepEqual(rebin([4, 8], [0, 2], [0.5, 1.5], 2), [2, 4]);
  assert.deepEqual(rebin([4, 8], [0, 2], [5, 6], 2), [0, 0]);
});

test('the stream-line state survives the URL (field, rake, count, selection, style)', () => {
  const base = { ...defaultView(), dataset: 'disk', attribute: 'Temp' };
  const lines = {
    ...base.lines, on: true, points: true, field: 'Velocity', seeds: 'rake', from: [0, -5, 2], to: [0, 5.5, 2], count: 300,
    select: { box: [[-1, -1, 0], [1, 2, 3]] }, ghost: 0.3, flow: 'dashes', depth: 0.25, animate: false, pointValues: [0.1, 0.2],
  };
  const view = { ...base, lines };
  const hash = viewToHash(view);
  assert.match(hash, /mode=dvr\+lines\+points/);
  assert.match(hash, /lseeds=rake:0,-5,2,0,5.5,2,300/);
  assert.deepEqual(viewFromHash(`#${hash}`), view);
  for (const select of [{ lines: [1, 4, 9] }, { pixel: [0.25, 0.5] }, null]) {
    const v = { ...base, lines: { ...base.lines, on: true, select } };
    assert.deepEqual(viewFromHash(`#${viewToHash(v)}`).lines.select, select);
  }
  const dense = { ...base, dvr: false, lines: { ...base.lines, on: true, count: 20 } };
  assert.deepEqual(viewFromHash(`#${viewToHash(dense)}`), dense, 'lines alone: the volume stays off');
});

test('a hostile stream-line fragment leaves the line defaults', () => {
  for (const hash of ['#lseeds=rake:1,2,3&lselect=ids:-1,2&lflow=sparks&ldepth=x', '#lseeds=dense:100000&lselect=box:1,2,3', '#lseeds=rake:1,2,3,4,5,6,0&lselect=pick:2,0.5&lfield=a%20b',
    `#lselect=ids:${Array.from({ length: 5000 }, (_, i) => i).join(',')}`]) {
    const lines = viewFromHash(hash).lines;
    assert.equal(lines.seeds, 'dense', hash);
    assert.equal(lines.count, 12, hash);
    assert.equal(lines.select, null, hash);
    assert.equal(lines.flow, 'arrows', hash);
    assert.equal(lines.depth, 1, hash);
    assert.equal(lines.field, null, hash);
  }
});

test('what is visible: the box, cut by the clip planes', () => {
  const box = { min: [0, 0, 0], max: [2, 1, 1] };
  const sorted = (points) => points.map((p) => p.map((v) => +v.toFixed(9))).sort((a, b) => a[0] - b[0] || a[1] - b[1] || a[2] - b[2]);
  assert.equal(visibleCorners(box).length, 8);
  // x <= 1 keeps the half box; inverted, the other half
  assert.deepEqual(sorted(visibleCorners(box, [{ normal: [2, 0, 0], offset: 2, invert: false }])).map((p) => p[0]), [0, 0, 0, 0, 1, 1, 1, 1]);
  assert.deepEqual(sorted(visibleCorners(box, [{ normal: [1, 0, 0], offset: 1, invert: true }])).map((p) => p[0]), [1, 1, 1, 1, 2, 2, 2, 2]);
  // a diagonal cut through a unit cube's corner: a tetrahedron of 4 corners
  assert.deepEqual(sorted(visibleCorners({ min: [0, 0, 0], max: [1, 1, 1] }, [{ normal: [1, 1, 1], offset: 1 }])), [[0, 0, 0], [0, 0, 1], [0, 1, 0], [1, 0, 0]]);
  assert.deepEqual(visibleCorners(box, [{ normal: [1, 0, 0], offset: -1 }]), [], 'a clip that keeps nothing');
});

test('the camera: zoom at the cursor keeps the point there; fit frames the points', () => {
  const camera = new OrbitCamera({ eye: [0, 0, 10], target: [0, 0, 0], up: [0, 1, 0], fov: 30 });
  const height = camera.visibleHeight();
  // the point at (0.25, -0.1) view heights from the middle, on the plane through the target
  const point = [0.25 * height, 0.1 * height, 0];
  camera.zoomAt(0.5, 0.25, -0.1);
  const after = camera.visibleHeight();
  assert.ok(Math.abs(after - height / 2) < 1e-9);
  const offset = [(point[0] - camera.target[0]) / after, (point[1] - camera.target[1]) / after];
  assert.ok(Math.abs(offset[0] - 0.25) < 1e-9 && Math.abs(offset[1] - 0.1) < 1e-9, `the point is still under the cursor: ${offset}`);
  camera.centreOn([1, 2, -3]);
  assert.deepEqual(camera.target, [1, 2, -3]);
  assert.deepEqual(camera.basis().forward.map((v) => +v.toFixed(12)), [0, 0, -1], 'the direction is kept');
  camera.fit([[-1, -1, -1], [1, 1, 1]], 2, 1);
  assert.deepEqual(camera.target.map((v) => +v.toFixed(12)), [0, 0, 0]);
  // the near corners (z = 1) just fit the height: distance 1 / tan(15°) + 1
  assert.ok(Math.abs(camera.eye[2] - (1 / Math.tan(Math.PI / 12) + 1)) < 1e-9, `${camera.eye}`);
});

test('none of the modes, a log scale, a background and legend titles survive the URL', () => {
  const view = { ...full(), dvr: false, iso: false, surface: false, logScale: true, background: [1, 1, 1], isoColorBy: 'Pres', legendTitles: { attribute: 'T (K) & more', iso: 'p', lines: '|U|' } };
  const hash = viewToHash(view);
  assert.match(hash, /mode=slice/);
  assert.deepEqual(viewFromHash(`#${hash}`), view);
  // a mode of nothing known keeps the default; a malformed background is dropped
  assert.equal(viewFromHash('#mode=xray&bg=zz0000').dvr, true);
  assert.equal(viewFromHash('#mode=xray&bg=zz0000').background, null);
});

test('a log scale sends the colours evenly in log10 over a range above 0, and not over one reaching 0', () => {
  const view = { ...defaultView(), attribute: 'p', range: [1, 1000], logScale: true };
  const colors = tfBody(view, 1).colors;
  assert.equal(colors.length, 64);
  assert.ok(Math.abs(colors[0][0] - 1) < 1e-12 && Math.abs(colors.at(-1)[0] - 1000) < 1e-9);
  assert.deepEqual(colors.at(-1).slice(1), colorAt(view.colors, 1));
  // the value 10 (a third of the way in log10) takes the colour a third along the map
  const k = 21;  // 63 / 3
  assert.ok(Math.abs(colors[k][0] - 10) < 1e-9);
  assert.deepEqual(colors[k].slice(1), colorAt(view.colors, 1 / 3));
  assert.equal(tfBody({ ...view, range: [0, 1000] }, 1).colors.length, view.colors.length, 'linear where the range reaches 0');
});
