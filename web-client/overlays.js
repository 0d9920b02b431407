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

// ---------- the legends ----------

// A legend: { key, title, caption (what it colours), colors ([[t, r, g, b], ...] along the
// bar), range [lo, hi], log (the bar spans log10 of the range) }.

export const legendLabel = (v) => (Math.abs(v) >= 1e5 || (Math.abs(v) < 1e-3 && v !== 0) ? v.toExponential(2) : String(+v.toPrecision(4)));

// Where `value` lies along a legend's bar, 0..1.
export function barPosition(value, [lo, hi], log = false) {
  if (log && lo > 0) return (Math.log10(value) - Math.log10(lo)) / (Math.log10(hi) - Math.log10(lo));
  return (value - lo) / (hi - lo);
}

// The values between the ends worth a tick: round numbers (1, 2 or 5 times a power of ten)
// about `count` of them, or on a log bar the powers of ten (with 2 and 5 times them when few);
// none nearer an end than a fifth of the bar, where they would run into its end labels.
export function legendTicks(range, log = false, count = 4) {
  const [lo, hi] = range;
  let values = [];
  if (log && lo > 0) {
    for (let e = Math.floor(Math.log10(lo)); e <= Math.ceil(Math.log10(hi)); ++e) values.push(10 ** e);
    if (values.length < 4) values = values.flatMap((v) => [v, 2 * v, 5 * v]);
  } else {
    const raw = (hi - lo) / count, power = 10 ** Math.floor(Math.log10(raw));
    const step = [1, 2, 5, 10].map((m) => m * power).find((s) => s >= raw) ?? raw;
    for (let v = Math.ceil(lo / step) * step; v < hi; v += step) values.push(+v.toPrecision(12));
  }
  return values.filter((v) => {
    const t = barPosition(v, range, log);
    return t >= 0.2 && t <= 0.8;
  });
}

// The legends over the view, in `container`: a title the user can edit (onTitle(key, text);
// empty: the default again), what it colours, the bar and its ticks.
export function showLegends(container, legends, onTitle) {
  container.hidden = !legends.length;
  container.replaceChildren(...legends.map((legend) => {
    const box = Object.assign(document.createElement('div'), { className: 'legend' });
    box.dataset.key = legend.key;
    const title = Object.assign(document.createElement('span'), { className: 'legend-title', textContent: legend.title, title: 'the legend\'s title: click to edit' });
    title.contentEditable = 'plaintext-only';
    title.spellcheck = false;
    title.addEventListener('keydown', (e) => {
      e.stopPropagation();  // typing is not a shortcut
      if (e.key === 'Enter' || e.key === 'Escape') title.blur();
    });
    title.addEventListener('blur', () => onTitle(legend.key, title.textContent.trim()));
    const caption = Object.assign(document.createElement('span'), { className: 'legend-caption', textContent: legend.caption });
    if (legend.classes) {  // categories: a swatch and a name each
      const list = Object.assign(document.createElement('div'), { className: 'legend-classes' });
      for (const c of legend.classes) {
        const item = Object.assign(document.createElement('span'), { className: 'legend-class' });
        const swatch = Object.assign(document.createElement('span'), { className: 'legend-swatch' });
        swatch.style.background = `rgb(${c.color.map((x) => Math.round(255 * x)).join(',')})`;
        item.append(swatch, document.createTextNode(c.label));
        list.append(item);
      }
      box.append(title, caption, list);
      return box;
    }
    const bar = Object.assign(document.createElement('canvas'), { className: 'legend-bar', width: 200, height: 12 });
    drawColorBar(bar.getContext('2d'), legend.colors, 0, 0, bar.width, bar.height);
    const ticks = Object.assign(document.createElement('div'), { className: 'legend-ticks' });
    const tick = (value, align, t) => {
      const span = Object.assign(document.createElement('span'), { textContent: legendLabel(value) });
      span.dataset.align = align;
      span.style.left = `${(100 * t).toFixed(2)}%`;
      return span;
    };
    ticks.append(tick(legend.range[0], 'start', 0), ...legendTicks(legend.range, legend.log).map((v) => tick(v, 'middle', barPosition(v, legend.range, legend.log))), tick(legend.range[1], 'end', 1));
    box.append(title, caption, bar, ticks);
    return box;
  }));
}

// One legend composited at (x0, y0) with scale s: its box, title, bar, tick marks and labels,
// in an ink chosen from what is under the box once darkened (never the bar's colours).
function drawLegend(g, legend, x0, y0, s) {
  const pad = 10 * s, barWidth = Math.round(220 * s), barHeight = Math.round(14 * s), font = Math.round(12 * s);
  const boxWidth = barWidth + 2 * pad;
  const boxHeight = legend.classes ? 3 * pad + font + legend.classes.length * (font + pad / 2) : barHeight + 3 * font + 3 * pad;
  g.fillStyle = 'rgba(0, 0, 0, 0.55)';
  g.fillRect(x0, y0, boxWidth, boxHeight);
  const ink = inkOn(meanColour(g, x0, y0, boxWidth, boxHeight));
  g.fillStyle = ink;
  g.font = `bold ${font}px system-ui, sans-serif`;
  g.textBaseline = 'top';
  g.textAlign = 'left';
  g.fillText(legend.title, x0 + pad, y0 + pad, barWidth);
  if (legend.classes) {  // categories: a swatch and a name each, below the title
    g.font = `${font}px system-ui, sans-serif`;
    legend.classes.forEach((c, k) => {
      const y = y0 + 2 * pad + font + k * (font + pad / 2);
      g.fillStyle = `rgb(${c.color.map((x) => Math.round(255 * x)).join(',')})`;
      g.fillRect(x0 + pad, y, font, font);
      g.fillStyle = ink;
      g.fillText(c.label, x0 + 2 * pad + font, y, barWidth - font - pad);
    });
    return boxWidth;
  }
  // what it colours after the title, where it fits
  const titleWidth = g.measureText(legend.title).width;
  g.font = `${font}px system-ui, sans-serif`;
  const caption = legend.caption ? `  (${legend.caption})` : '';
  if (caption && titleWidth + g.measureText(caption).width <= barWidth) g.fillText(caption, x0 + pad + titleWidth, y0 + pad);
  const barX = Math.round(x0 + pad), barY = y0 + 2 * pad + font;
  drawColorBar(g, legend.colors, barX, Math.round(barY), barWidth, barHeight);
  g.fillStyle = ink;  // drawColorBar left its last colour
  const marks = [legend.range[0], ...legendTicks(legend.range, legend.log), legend.range[1]];
  for (const v of marks) g.fillRect(Math.round(barX + barPosition(v, legend.range, legend.log) * (barWidth - 1)), Math.round(barY + barHeight), Math.max(1, Math.round(s)), Math.round(pad / 3));
  g.font = `${font}px system-ui, sans-serif`;
  const labelY = barY + barHeight + pad / 2;
  g.fillText(legendLabel(legend.range[0]), x0 + pad, labelY);
  g.textAlign = 'center';
  for (const v of legendTicks(legend.range, legend.log)) g.fillText(legendLabel(v), barX + barPosition(v, legend.range, legend.log) * barWidth, labelY);
  g.textAlign = 'right';
  g.fillText(legendLabel(legend.range[1]), x0 + pad + barWidth, labelY);
  return boxWidth;
}

// The still (an ImageBitmap) with the bounding box (`box`: {camera, bounds}, the camera the
// still was drawn with; null: none) and the legends side by side in its lower left (the first
// in the corner), scaled to the image's size; resolves to a PNG blob.
export async function composeStill(bitmap, { legends, box = null }) {
  const canvas = document.createElement('canvas');
  canvas.width = bitmap.width;
  canvas.height = bitmap.height;
  const g = canvas.getContext('2d', { willReadFrequently: true });
  g.drawImage(bitmap, 0, 0);
  if (box) drawBox(g, box.camera, box.bounds, bitmap.width, bitmap.height, inkOn(backgroundOf(g, bitmap.width, bitmap.height)));
  const s = Math.max(1, Math.min(bitmap.width, bitmap.height) / 600);  // 1 at 800x600
  const pad = 10 * s, boxHeight = Math.round(14 * s) + 3 * Math.round(12 * s) + 3 * pad;
  const boxWidth = Math.round(220 * s) + 2 * pad;
  let x = pad, y = bitmap.height - boxHeight - pad;
  for (const legend of legends) {
    if (x > pad && x + boxWidth > bitmap.width) [x, y] = [pad, y - boxHeight - pad];  // a row up
    x += drawLegend(g, legend, x, y, s) + pad;
  }
  return new Promise((resolve) => canvas.toBlob(resolve, 'image/png'));
}
