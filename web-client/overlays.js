// What the client draws over the server's frames: the orientation axes (they turn with the
// camera) and the colour legend, on screen and composited onto saved stills.
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

const label = (v) => (Math.abs(v) >= 1e5 || (Math.abs(v) < 1e-3 && v !== 0) ? v.toExponential(2) : String(+v.toPrecision(4)));

// The still (an ImageBitmap) with the legend, dataset and attribute in its lower left,
// scaled to the image's size; resolves to a PNG blob.
export async function composeStill(bitmap, { colors, range, attribute, dataset }) {
  const canvas = document.createElement('canvas');
  canvas.width = bitmap.width;
  canvas.height = bitmap.height;
  const g = canvas.getContext('2d');
  g.drawImage(bitmap, 0, 0);
  const s = Math.max(1, Math.min(bitmap.width, bitmap.height) / 600);  // 1 at 800x600
  const pad = 10 * s, barWidth = Math.round(220 * s), barHeight = Math.round(14 * s), font = Math.round(12 * s);
  const boxWidth = barWidth + 2 * pad, boxHeight = barHeight + 3 * font + 3 * pad;
  const x0 = pad, y0 = bitmap.height - boxHeight - pad;
  g.fillStyle = 'rgba(0, 0, 0, 0.55)';
  g.fillRect(x0, y0, boxWidth, boxHeight);
  g.fillStyle = '#eef';
  g.font = `bold ${font}px system-ui, sans-serif`;
  g.textBaseline = 'top';
  g.fillText(`${dataset} — ${attribute}`, x0 + pad, y0 + pad, barWidth);
  const barY = y0 + 2 * pad + font;
  drawColorBar(g, colors, Math.round(x0 + pad), Math.round(barY), barWidth, barHeight);
  g.font = `${font}px system-ui, sans-serif`;
  g.fillText(label(range[0]), x0 + pad, barY + barHeight + pad / 2);
  g.textAlign = 'right';
  g.fillText(label(range[1]), x0 + pad + barWidth, barY + barHeight + pad / 2);
  return new Promise((resolve) => canvas.toBlob(resolve, 'image/png'));
}
