// The browser's side of the tetrascope WebSocket protocol (the C++ side is
// protocol/src/protocol.cpp; both are tested against protocol/testdata/).
//   checkMessage(text, limits) -> {type, id} or throws ProtocolError(code, message, id)
//   encodeMessage(type, id, fields) -> JSON text
//   decodeFrame(arrayBuffer, limits) -> {header, payload}
//   encodeFrameHeader(header) -> Uint8Array (tests, tools)

import { planeCheckers } from './planes.js';

export const VERSION = 1;
export const FRAME_MAGIC = 0x31465354;
export const FRAME_HEADER_BYTES = 48;
export const DEFAULT_LIMITS = Object.freeze({
  max_message_bytes: 64 * 1024,
  max_image_side: 4096,
  max_isovalues: 16,
  max_tf_points: 256,
});

// lines.set and points.set ranges (protocol.h kMaxLineSeeds ... kMaxPointSizePixels)
export const LINE_LIMITS = Object.freeze({
  max_seeds: 2000,
  max_dense_cells: 64,
  max_steps: 100000,
  max_selected: 4096,
  max_line_width: 32,
  max_point_size: 64,
});
export const MAX_HIDDEN_REGIONS = 1024;  // regions.set hidden: ids below this, at most this many
export const MAX_TIME_STEP = 99999;  // time.set step and prefetch: 0 to this
export const MODE_PARTS = ['dvr', 'iso', 'isosurface', 'surface', 'lines', 'points', 'tensors', 'slice'];
// tensors.set (protocol.h kMaxTensorCells): seeding cells, and the colours a tensor's points take
export const MAX_TENSOR_CELLS = 32;
export const TENSOR_COLORS = ['class', 'lambda1', 'lambda2', 'lambda3', 'trace', 'von_mises', 'fa', 'cl', 'cp', 'cs'];

export class ProtocolError extends Error {
  constructor(code, message, id = null) {
    super(message);
    this.code = code;
    this.id = id;
  }
}

const isNumber = (v) => typeof v === 'number' && Number.isFinite(v);
const isWhole = (v) => Number.isInteger(v) && v >= 0;

function fields(object, id) {
  const fail = (field, what) => {
    throw new ProtocolError('bad_field', `${field}: ${what}`, id);
  };
  const find = (field) => (object[field] === undefined || object[field] === null ? undefined : object[field]);
  const number = (field, v, lo, hi) => {
    if (typeof v !== 'number') fail(field, 'expected a number');
    if (!isNumber(v) || v < lo || v > hi) fail(field, `out of range [${lo}, ${hi}]`);
    return v;
  };
  const optNumber = (field, lo, hi) => (find(field) === undefined ? undefined : number(field, find(field), lo, hi));
  const integer = (field, lo, hi) => {
    const v = find(field);
    if (v === undefined) return undefined;
    if (!isWhole(v)) fail(field, 'expected a whole number');
    if (v < lo || v > hi) fail(field, `out of range [${lo}, ${hi}]`);
    return v;
  };
  const boolean = (field) => {
    const v = find(field);
    if (v !== undefined && typeof v !== 'boolean') fail(field, 'expected true or false');
    return v;
  };
  const string = (field, max) => {
    const v = find(field);
    if (v === undefined) return undefined;
    if (typeof v !== 'string') fail(field, 'expected a string');
    if (new TextEncoder().encode(v).length > max) fail(field, `longer than ${max} characters`);
    return v;
  };
  const vector3 = (field) => {
    const v = find(field);
    if (v === undefined) fail(field, 'missing');
    if (!Array.isArray(v) || v.length !== 3) fail(field, 'expected [x, y, z]');
    return v.map((x) => number(field, x, -1e30, 1e30));
  };
  const points = (field, width, max) => {
    const v = find(field);
    if (v === undefined) return;
    if (!Array.isArray(v)) fail(field, 'expected a list of points');
    if (v.length > max) fail(field, `more than ${max} points`);
    let previous = -Infinity;
    v.forEach((p, i) => {
      const name = `${field}[${i}]`;
      if (!Array.isArray(p) || p.length !== width) fail(name, `expected ${width} numbers`);
      const value = number(name, p[0], -1e30, 1e30);
      if (value < previous) fail(name, 'values must ascend');
      previous = value;
      for (let k = 1; k < width; ++k) number(name, p[k], 0, 1);
    });
  };
  return { fail, find, number, optNumber, integer, boolean, string, vector3, points };
}

const checkers = {
  hello(f, limits, id) {
    const v = f.find('version');
    if (v === undefined) f.fail('version', 'missing');
    if (!isWhole(v)) f.fail('version', 'expected a whole number');
    if (v !== VERSION) throw new ProtocolError('unsupported_version', `this client speaks protocol version ${VERSION}, the peer ${v}`, id);
    f.string('token', 1024);
  },
  'dataset.open'(f) {
    if (!f.string('name', 128)) f.fail('name', 'missing');
  },
  'camera.set'(f) {
    const eye = f.vector3('eye');
    const target = f.vector3('target');
    const up = f.find('up') === undefined ? [0, 1, 0] : f.vector3('up');
    f.optNumber('fov', 1, 170);
    f.boolean('orthographic');
    f.optNumber('height', 1e-30, 1e30);
    f.boolean('interacting');
    const d = [target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]];
    const dl = Math.hypot(...d);
    if (!(dl > 0)) f.fail('target', 'equals eye');
    const c = [d[1] * up[2] - d[2] * up[1], d[2] * up[0] - d[0] * up[2], d[0] * up[1] - d[1] * up[0]];
    if (!(Math.hypot(...c) > 1e-9 * dl * Math.hypot(...up))) f.fail('up', 'zero or parallel to the view direction');
  },
  'tf.set'(f, limits) {
    f.string('attribute', 128);
    const colormap = f.string('colormap', 64);
    if (colormap !== undefined && !COLORMAPS.includes(colormap)) f.fail('colormap', `unknown '${colormap}' (viridis, plasma, cool-warm, grayscale)`);
    const component = f.string('component', 16);
    if (component !== undefined && !COMPONENTS.includes(component)) f.fail('component', `unknown '${component}' (magnitude, x, y, z)`);
    const r = f.find('range');
    if (r !== undefined) {
      if (!Array.isArray(r) || r.length !== 2) f.fail('range', 'expected [low, high]');
      const lo = f.number('range', r[0], -1e30, 1e30);
      const hi = f.number('range', r[1], -1e30, 1e30);
      if (!(hi > lo)) f.fail('range', 'high must exceed low');
    }
    f.points('opacity', 2, limits.max_tf_points);
    f.points('colors', 4, limits.max_tf_points);
  },
  'mode.set'(f) {
    const mode = f.string('mode', 64);
    if (!mode) f.fail('mode', 'missing');
    for (const part of mode.split('+')) {
      if (!MODE_PARTS.includes(part)) f.fail('mode', `unknown mode '${part}' (dvr, iso, surface, lines, points, slice or combinations such as dvr+lines)`);
    }
    f.boolean('wireframe');
    f.boolean('box');
    const background = f.find('background');
    if (background !== undefined) {
      if (!Array.isArray(background) || background.length !== 3) f.fail('background', 'expected [r, g, b], each 0 to 1');
      background.forEach((v) => f.number('background', v, 0, 1));
    }
  },
  'iso.set'(f, limits) {
    const values = f.find('values');
    if (values === undefined) f.fail('values', 'missing');
    if (!Array.isArray(values)) f.fail('values', 'expected a list of numbers');
    if (values.length > limits.max_isovalues) f.fail('values', `more than ${limits.max_isovalues} isovalues`);
    values.forEach((v) => f.number('values', v, -1e30, 1e30));
    f.optNumber('opacity', 0, 1);
    f.string('color_by', 128);
  },
  'lod.set'(f) {
    const budget = f.integer('budget', 1, 4000000000);
    const interaction = f.integer('interaction_budget', 1, 4000000000);
    const maxError = f.optNumber('max_error', 0, 1e30);
    if (budget === undefined && interaction === undefined && maxError === undefined) f.fail('budget', 'missing (budget, interaction_budget or max_error)');
  },
  'view.resize'(f, limits) {
    if (!f.integer('width', 16, limits.max_image_side)) f.fail('width', 'missing');
    if (!f.integer('height', 16, limits.max_image_side)) f.fail('height', 'missing');
  },
  'quality.set'(f) {
    f.integer('interaction', 1, 100);
    f.integer('still', 1, 100);
    const codec = f.string('still_codec', 8);
    if (codec !== undefined && codec !== 'jpeg' && codec !== 'png') f.fail('still_codec', 'expected jpeg or png');
    f.optNumber('interaction_scale', 0.25, 1);
  },
  'lines.set'(f) {
    f.string('field', 128);
    const seeds = f.find('seeds');
    const dense = seeds === 'dense';
    if (seeds !== undefined && !dense) {
      if (!Array.isArray(seeds)) f.fail('seeds', 'expected "dense" or rake ends [[x, y, z], [x, y, z]]');
      twoPoints(f, 'seeds', seeds);
    }
    if (f.find('count') !== undefined) {
      if (seeds === undefined) f.fail('count', 'needs seeds ("dense" or a rake) in the same message');
      f.integer('count', 1, dense ? LINE_LIMITS.max_dense_cells : LINE_LIMITS.max_seeds);
    }
    f.integer('max_steps', 1, LINE_LIMITS.max_steps);
    const select = f.find('select');
    if (select !== undefined) {
      if (typeof select !== 'object' || Array.isArray(select)) f.fail('select', 'expected an object with lines, box or pixel');
      const lines = select.lines ?? undefined;
      if (lines !== undefined) {
        if (!Array.isArray(lines)) f.fail('select.lines', 'expected a list of line ids');
        if (lines.length > LINE_LIMITS.max_selected) f.fail('select.lines', `more than ${LINE_LIMITS.max_selected} lines`);
        for (const id of lines) if (!isWhole(id) || id > 0xffffffff) f.fail('select.lines', 'expected whole numbers');
      }
      const box = select.box ?? undefined;
      if (box !== undefined) {
        const b = twoPoints(f, 'select.box', box);
        if (!(b[0] <= b[3] && b[1] <= b[4] && b[2] <= b[5])) f.fail('select.box', 'the first corner must be the low one');
      }
      const pixel = select.pixel ?? undefined;
      if (pixel !== undefined) {
        if (!Array.isArray(pixel) || pixel.length !== 2) f.fail('select.pixel', 'expected [x, y], fractions of the image');
        pixel.forEach((v) => f.number('select.pixel', v, 0, 1));
      }
    }
    f.optNumber('ghost_opacity', 0.01, 1);
    f.optNumber('line_width', 1, LINE_LIMITS.max_line_width);
    f.boolean('halos');
    const flow = f.string('flow', 16);
    if (flow !== undefined && !['arrows', 'dashes', 'none'].includes(flow)) f.fail('flow', 'expected arrows, dashes or none');
    f.optNumber('depth_correction', 0, 1);
    f.optNumber('dash_phase', 0, 1);
  },
  'points.set'(f, limits) {
    const values = f.find('values');
    if (values !== undefined) {
      if (!Array.isArray(values)) f.fail('values', 'expected a list of numbers');
      if (values.length > limits.max_isovalues) f.fail('values', `more than ${limits.max_isovalues} isovalues`);
      values.forEach((v) => f.number('values', v, -1e30, 1e30));
    }
    f.optNumber('size', 0, LINE_LIMITS.max_point_size);
  },
  'tensors.set'(f) {
    const field = f.string('field', 128);
    if (field === '') f.fail('field', 'empty');
    for (const name of ['density', 'surface_density']) {
      const n = f.find(name);
      if (n !== undefined && (!isWhole(n) || n > MAX_TENSOR_CELLS)) f.fail(name, `out of range [0, ${MAX_TENSOR_CELLS}]`);
    }
    f.optNumber('min_cl', 0, 1);
    f.optNumber('min_cp', 0, 1);
    const color = f.string('color', 32);
    if (color !== undefined && !TENSOR_COLORS.includes(color)) f.fail('color', `expected ${TENSOR_COLORS.join(', ')}`);
    f.optNumber('size', 0, LINE_LIMITS.max_point_size);
  },
  ping() {},
  'regions.set'(f) {
    const hidden = f.find('hidden');
    if (hidden === undefined) f.fail('hidden', 'missing');
    if (!Array.isArray(hidden)) f.fail('hidden', 'expected a list of region ids');
    if (hidden.length > MAX_HIDDEN_REGIONS) f.fail('hidden', `more than ${MAX_HIDDEN_REGIONS} regions`);
    for (const id of hidden) if (!isWhole(id) || id >= MAX_HIDDEN_REGIONS) f.fail('hidden', `expected region ids from 0 to ${MAX_HIDDEN_REGIONS - 1}`);
  },
  'time.set'(f) {
    if (f.integer('step', 0, MAX_TIME_STEP) === undefined) f.fail('step', 'missing');
    f.integer('prefetch', 0, MAX_TIME_STEP);
  },
  ...planeCheckers,
};

function twoPoints(f, field, v) {
  if (!Array.isArray(v) || v.length !== 2 || !Array.isArray(v[0]) || v[0].length !== 3 || !Array.isArray(v[1]) || v[1].length !== 3)
    f.fail(field, 'expected [[x, y, z], [x, y, z]]');
  return [...v[0], ...v[1]].map((x) => f.number(field, x, -1e30, 1e30));
}

export function checkMessage(text, limits = DEFAULT_LIMITS) {
  const bytes = new TextEncoder().encode(text).length;
  if (bytes > limits.max_message_bytes) throw new ProtocolError('too_large', `message of ${bytes} bytes; the limit is ${limits.max_message_bytes}`);
  let object;
  try {
    object = JSON.parse(text);
  } catch {
    object = undefined;
  }
  if (object === null || typeof object !== 'object' || Array.isArray(object)) throw new ProtocolError('bad_json', 'a control message is one JSON object');
  const id = isWhole(object.id) && object.id <= 0xffffffff ? object.id : null;
  if (typeof object.type !== 'string') throw new ProtocolError('bad_message', 'missing "type"', id);
  if (id === null) throw new ProtocolError('bad_message', '"id" must be a whole number 0..4294967295');
  const check = checkers[object.type];
  if (!check) throw new ProtocolError('unknown_type', `unknown message type '${object.type}'`, id);
  check(fields(object, id), limits, id);
  return { type: object.type, id };
}

export function encodeMessage(type, id, body = {}) {
  return JSON.stringify({ type, id, ...body });
}

const CODECS = ['jpeg', 'png'];
// the colormaps the renderer draws (protocol/transfer_function.h kColormapNames)
export const COLORMAPS = ['viridis', 'plasma', 'cool-warm', 'grayscale'];
// tf.set component: what of a vector attribute is drawn (x, y, z: components 0, 1, 2)
export const COMPONENTS = ['magnitude', 'x', 'y', 'z'];

export function decodeFrame(buffer, limits = DEFAULT_LIMITS) {
  const bytes = buffer instanceof Uint8Array ? buffer : new Uint8Array(buffer);
  if (bytes.length < FRAME_HEADER_BYTES) throw new ProtocolError('bad_message', `frame shorter than its ${FRAME_HEADER_BYTES}-byte header`);
  const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  if (view.getUint32(0, true) !== FRAME_MAGIC) throw new ProtocolError('bad_message', 'frame: bad magic');
  const version = view.getUint16(4, true);
  if (version !== VERSION) throw new ProtocolError('unsupported_version', `frame: version ${version}`);
  const codec = view.getUint8(6);
  if (codec > 1) throw new ProtocolError('bad_message', `frame: unknown codec ${codec}`);
  const flags = view.getUint8(7);
  if (flags > 3) throw new ProtocolError('bad_message', 'frame: unknown flags');
  if (flags === 3) throw new ProtocolError('bad_message', 'frame: both still and refining');
  const estimatedError = view.getFloat32(44, true);
  if (!(estimatedError >= 0) || !Number.isFinite(estimatedError)) throw new ProtocolError('bad_message', 'frame: estimated error not a finite number >= 0');
  const header = {
    frame_number: view.getUint32(8, true),
    message_id: view.getUint32(12, true),
    width: view.getUint32(16, true),
    height: view.getUint32(20, true),
    codec: CODECS[codec],
    still: (flags & 1) === 1,
    refining: (flags & 2) === 2,
    tets: Number(view.getBigUint64(24, true)),
    render_ms: view.getFloat32(32, true),
    encode_ms: view.getFloat32(36, true),
    payload_bytes: view.getUint32(40, true),
    estimated_error: estimatedError,
  };
  if (header.width === 0 || header.height === 0 || header.width > limits.max_image_side || header.height > limits.max_image_side) {
    throw new ProtocolError('bad_message', `frame: image size ${header.width}x${header.height} outside 1..${limits.max_image_side}`);
  }
  if (header.payload_bytes + FRAME_HEADER_BYTES !== bytes.length) {
    throw new ProtocolError('bad_message', `frame: header says ${header.payload_bytes} payload bytes, message has ${bytes.length - FRAME_HEADER_BYTES}`);
  }
  return { header, payload: bytes.subarray(FRAME_HEADER_BYTES) };
}

export function encodeFrameHeader(h) {
  const bytes = new Uint8Array(FRAME_HEADER_BYTES);
  const view = new DataView(bytes.buffer);
  view.setUint32(0, FRAME_MAGIC, true);
  view.setUint16(4, VERSION, true);
  view.setUint8(6, CODECS.indexOf(h.codec));
  view.setUint8(7, (h.still ? 1 : 0) | (h.refining ? 2 : 0));
  view.setUint32(8, h.frame_number, true);
  view.setUint32(12, h.message_id, true);
  view.setUint32(16, h.width, true);
  view.setUint32(20, h.height, true);
  view.setBigUint64(24, BigInt(h.tets), true);
  view.setFloat32(32, h.render_ms, true);
  view.setFloat32(36, h.encode_ms, true);
  view.setUint32(40, h.payload_bytes, true);
  view.setFloat32(44, h.estimated_error ?? 0, true);
  return bytes;
}
