// What the client draws over the server's frames: the orientation axes (they turn with the
// camera), the dataset's bounding box and the colour legend, on screen and composited onto
// saved stills, in inks chosen from what lies under them (a colormap's end colour or the
// renderer's near-black lines can vanish on a dark background).
import { colorAt, toCss } from './colormaps.js';

const kAxes = [
  { label: 'X', direction: [1, 0, 0], color: '#e8505b' },
  { label: 'Y', direction: [0, 1, 0], color: '#5bd46a' },
  { label: 'Z', direction: [0, 0, 1], color: '#4f8cf0' },
];

const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];

// basis: the camera's {right, up, forward} in world space
export function drawAxes(canvas, basis) {
  const g = canvas.getContext('2d');
  const w = canvas.width, h = canvas.height, cx = w / 2, cy = h / 2, length = Math.min(w, h) * 0.34;
  g.clearRect(0, 0, w, h);
  if (!basis) return;
  // the axes pointing away from the viewer first, so the near ones are drawn over them
  const axes = kAxes.map((a) => ({ ...a, x: dot(a.direction, basis.right), y: dot(a.direction, basis.up), depth: dot(a.direction, basis.forward) }));
  axes.sort((a, b) => b.depth - a.depth);
  g.lineCap = 'round';
  g.font = 'bold 12px system-ui, sans-serif';
  g.textAlign = 'center';
  g.textBaseline = 'middle';
  for (const a of axes) {
    const x = cx + a.x * length, y = cy - a.y * length;
    g.globalAlpha = a.depth > 0.2 ? 0.55 : 1;
    g.strokeStyle = a.color;
    g.lineWidth = 3;
    g.beginPath();
    g.moveTo(cx, cy);
    g.lineTo(x, y);
    g.stroke();
    g.fillStyle = a.color;
    g.fillText(a.label, cx + a.x * (length + 11), cy - a.y * (length + 11));
  }
  g.globalAlpha = 1;
}

// A horizontal colour bar of colour points [[t, r, g, b], ...].
export function drawColorBar(g, colors, x, y, width, height) {
  for (let i = 0; i < width; ++i) {
    g.fillStyle = toCss(colorAt(colors, i / Math.max(1, width - 1)));
    g.fillRect(x + i, y, 1, height);
  }
}

// ---------- inks ----------

const luminance = ([r, g, b]) => 0.2126 * r + 0.7152 * g + 0.0722 * b;  // 0..255 in, 0..255 out
const kLightInk = '#eef0f6', kDarkInk = '#15171c';

// The mean colour [r, g, b] (0..255) of a rectangle of `g`'s pixels.
export function meanColour(g, x, y, w, h) {
  const { data } = g.getImageData(Math.round(x), Math.round(y), Math.max(1, Math.round(w)), Math.max(1, Math.round(h)));
  const sum = [0, 0, 0];
  for (let i = 0; i < data.length; i += 4) for (let k = 0; k < 3; ++k) sum[k] += data[i + k];
  return sum.map((v) => v / (data.length / 4));
}

// Text or lines readable on a background of colour `rgb`.
export const inkOn = (rgb) => (luminance(rgb) > 140 ? kDarkInk : kLightInk);

// The image's background: the mean of its four corners (8 px squares), where the data rarely is.
export function backgroundOf(g, width, height) {
  const side = Math.max(1, Math.min(8, Math.floor(Math.min(width, height) / 4)));
  const corners = [[0, 0], [width - side, 0], [0, height - side], [width - side, height - side]].map(([x, y]) => meanColour(g, x, y, side, side));
  return [0, 1, 2].map((k) => corners.reduce((s, c) => s + c[k], 0) / 4);
}

// ---------- the bounding box ----------

const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const unit = (a) => a.map((v) => v / (Math.hypot(...a) || 1));
const kBoxEdges = [[0, 1], [2, 3], [4, 5], [6, 7], [0, 2], [1, 3], [4, 6], [5, 7], [0, 4], [1, 5], [2, 6], [3, 7]];

// The 12 edges of `bounds` ({min, max}) as the renderer's camera (camera.set's fields) shows
// them in a width x height image: the renderer's projection (vertical field of view, or the
// parallel view's height), edges cut at a near plane. Edges whose two faces turn away from
// the eye are drawn fainter, behind the data. `ink`: the lines' colour.
export function drawBox(g, camera, bounds, width, height, ink) {
  const forward = unit(sub(camera.target, camera.eye));
  const right = unit(cross(forward, camera.up));
  const up = cross(right, forward);
  const corners = [0, 1, 2, 3, 4, 5, 6, 7].map((i) => [0, 1, 2].map((k) => ((i >> k) & 1 ? bounds.max[k] : bounds.min[k])));
  const view = corners.map((p) => {
    const d = sub(p, camera.eye);
    return [dot(d, right), dot(d, up), dot(d, forward)];
  });
  const tanHalf = Math.tan((camera.fov * Math.PI) / 360);
  const size = Math.hypot(...sub(bounds.max, bounds.min)) || 1;
  const near = camera.orthographic ? -Infinity : size * 1e-4;
  const toPixel = ([x, y, z]) => {
    const half = camera.orthographic ? camera.height / 2 : z * tanHalf;
    return [width / 2 + (x / half) * (height / 2), height / 2 - (y / half) * (height / 2)];
  };
  // a face (axis k, side s) turns away when the eye is on its inner side
  const eyeInside = [0, 1, 2].map((k) => [camera.eye[k] > bounds.min[k], camera.eye[k] < bounds.max[k]]);
  const facesAway = (a, b) => {
    for (let k = 0; k < 3; ++k) if (((a >> k) & 1) === ((b >> k) & 1)) if (!eyeInside[k][(a >> k) & 1]) return false;
    return true;
  };
  g.save();
  g.strokeStyle = ink;
  g.lineCap = 'round';
  for (const [a, b] of kBoxEdges) {
    let p = view[a], q = view[b];
    if (p[2] < near && q[2] < near) continue;
    const cut = (from, to) => {  // the point of from->to on the near plane
      const t = (near - from[2]) / (to[2] - from[2]);
      return from.map((v, k) => v + t * (to[k] - v));
    };
    if (p[2] < near) p = cut(p, q);
    else if (q[2] < near) q = cut(q, p);
    const [x0, y0] = toPixel(p), [x1, y1] = toPixel(q);
    g.globalAlpha = facesAway(a, b) ? 0.45 : 0.9;
    g.lineWidth = Math.max(1, Math.min(width, height) / 500);
    g.beginPath();
    g.moveTo(x0, y0);
    g.lineTo(x1, y1);
    g.stroke();
  }
  g.restore();
}

// ---------- the legend ----------

const label = (v) => (Math.abs(v) >= 1e5 || (Math.abs(v) < 1e-3 && v !== 0) ? v.toExponential(2) : String(+v.toPrecision(4)));

// The still (an ImageBitmap) with the bounding box (`box`: {camera, bounds}, the camera the
// still was drawn with; null: none) and the legend, dataset and attribute in its lower left,
// scaled to the image's size; resolves to a PNG blob.
export async function composeStill(bitmap, { colors, range, attribute, dataset, box = null }) {
  const canvas = document.createElement('canvas');
  canvas.width = bitmap.width;
  canvas.height = bitmap.height;
  const g = canvas.getContext('2d', { willReadFrequently: true });
  g.drawImage(bitmap, 0, 0);
  if (box) drawBox(g, box.camera, box.bounds, bitmap.width, bitmap.height, inkOn(backgroundOf(g, bitmap.width, bitmap.height)));
  const s = Math.max(1, Math.min(bitmap.width, bitmap.height) / 600);  // 1 at 800x600
  const pad = 10 * s, barWidth = Math.round(220 * s), barHeight = Math.round(14 * s), font = Math.round(12 * s);
  const boxWidth = barWidth + 2 * pad, boxHeight = barHeight + 3 * font + 3 * pad;
  const x0 = pad, y0 = bitmap.height - boxHeight - pad;
  g.fillStyle = 'rgba(0, 0, 0, 0.55)';
  g.fillRect(x0, y0, boxWidth, boxHeight);
  // the labels' ink from what is under them now (the darkened still), never the bar's colours
  const ink = inkOn(meanColour(g, x0, y0, boxWidth, boxHeight));
  g.fillStyle = ink;
  g.font = `bold ${font}px system-ui, sans-serif`;
  g.textBaseline = 'top';
  g.fillText(`${dataset} — ${attribute}`, x0 + pad, y0 + pad, barWidth);
  const barY = y0 + 2 * pad + font;
  drawColorBar(g, colors, Math.round(x0 + pad), Math.round(barY), barWidth, barHeight);
  g.font = `${font}px system-ui, sans-serif`;
  g.fillStyle = ink;  // drawColorBar left its last colour
  g.fillText(label(range[0]), x0 + pad, barY + barHeight + pad / 2);
  g.textAlign = 'right';
  g.fillText(label(range[1]), x0 + pad + barWidth, barY + barHeight + pad / 2);
  return new Promise((resolve) => canvas.toBlob(resolve, 'image/png'));
}
