// clip.set and slice.set in the browser's codec (the C++ side: protocol/src/planes.cpp; both
// checked against protocol/testdata/planes.json). A plane is {normal: [x, y, z], offset: d}:
// n.x = d; a clip plane keeps n.x <= d (n.x >= d with invert).

export const MAX_CLIP_PLANES = 6;
export const MAX_SLICE_PLANES = 6;
const MAX_COORDINATE = 1e30;

function planeList(f, max) {
  const planes = f.find('planes');
  if (planes === undefined) return [];
  if (!Array.isArray(planes)) f.fail('planes', 'expected a list of {"normal": [x, y, z], "offset": d}');
  if (planes.length > max) f.fail('planes', `${planes.length} planes; at most ${max}`);
  return planes;
}

function checkPlane(f, plane, i, clip) {
  const name = `planes[${i}]`;
  if (plane === null || typeof plane !== 'object' || Array.isArray(plane)) f.fail(name, 'expected {"normal": [x, y, z], "offset": d}');
  const n = plane.normal;
  if (n === undefined || n === null) f.fail(`${name}.normal`, 'missing');
  if (!Array.isArray(n) || n.length !== 3) f.fail(`${name}.normal`, 'expected [x, y, z]');
  n.forEach((c) => f.number(`${name}.normal`, c, -MAX_COORDINATE, MAX_COORDINATE));
  if (plane.offset === undefined || plane.offset === null) f.fail(`${name}.offset`, 'missing');
  f.number(`${name}.offset`, plane.offset, -MAX_COORDINATE, MAX_COORDINATE);
  const length = Math.hypot(...n);
  if (!(length > 0) || !Number.isFinite(length)) f.fail(`${name}.normal`, 'zero length (a plane needs a direction)');
  if (clip && plane.invert !== undefined && plane.invert !== null && typeof plane.invert !== 'boolean') f.fail(`${name}.invert`, 'expected true or false');
}

export const planeCheckers = {
  'clip.set'(f) {
    planeList(f, MAX_CLIP_PLANES).forEach((p, i) => checkPlane(f, p, i, true));
    const box = f.find('box');
    if (box !== undefined) {
      if (typeof box !== 'object' || Array.isArray(box)) f.fail('box', 'expected {"min": [x, y, z], "max": [x, y, z]}');
      const corner = (key) => {
        const v = box[key];
        if (v === undefined || v === null) f.fail(`box.${key}`, 'missing');
        if (!Array.isArray(v) || v.length !== 3) f.fail(`box.${key}`, 'expected [x, y, z]');
        return v.map((c) => f.number(`box.${key}`, c, -MAX_COORDINATE, MAX_COORDINATE));
      };
      const min = corner('min');
      const max = corner('max');
      for (let k = 0; k < 3; ++k) if (!(min[k] <= max[k])) f.fail('box', `min exceeds max on axis ${'xyz'[k]}`);
    }
    f.boolean('crinkle');
  },
  probe(f, limits) {
    for (const axis of ['x', 'y']) {
      if (f.find(axis) === undefined) f.fail(axis, 'missing');
      f.number(axis, f.find(axis), 0, limits.max_image_side);
    }
  },
  'slice.set'(f) {
    planeList(f, MAX_SLICE_PLANES).forEach((p, i) => checkPlane(f, p, i, false));
    f.boolean('edges');
    f.boolean('lit');
  },
};

// probe.result's values as rows to show: [{name, value: number | null | [x, y, z], magnitude?}],
// the attribute shown first. A reply without `values` (an older server) gives its one
// attribute; malformed entries are left out (the server's reply, but read with care).
export function probeRows(result) {
  if (!result?.hit) return [];
  const num = (v) => (typeof v === 'number' && Number.isFinite(v) ? v : null);
  const rows = [];
  const values = result.values !== null && typeof result.values === 'object' && !Array.isArray(result.values) ? result.values : null;
  if (!values) return typeof result.attribute === 'string' ? [{ name: result.attribute, value: num(result.value) }] : [];
  for (const [name, v] of Object.entries(values)) {
    if (Array.isArray(v)) {
      if (v.length === 0 || v.length > 16) continue;
      const components = v.map(num);
      const m = num(result.magnitudes?.[name]);
      rows.push({ name, value: components, magnitude: m ?? (components.every((c) => c !== null) ? Math.hypot(...components) : null) });
    } else if (typeof v === 'number' || v === null) {
      rows.push({ name, value: num(v) });
    }
  }
  const shown = rows.findIndex((r) => r.name === result.attribute);
  if (shown > 0) rows.unshift(...rows.splice(shown, 1));
  return rows;
}
