// Where world points land in a view, computed from the camera a page sent (camera.set's fields:
// eye, target, up, fov in degrees, orthographic with its visible height), without the page's
// own camera code: the browser tests measure navigation with it.
const sub = (a, b) => a.map((v, i) => v - b[i]);
const dot = (a, b) => a.reduce((s, v, i) => s + v * b[i], 0);
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const unit = (a) => a.map((v) => v / Math.hypot(...a));

// The pixel (x right, y down, from the top-left corner) of world point `p` in a width x height
// view of `camera`.
export function project(camera, width, height, p) {
  const forward = unit(sub(camera.target, camera.eye));
  const right = unit(cross(forward, camera.up));
  const up = cross(right, forward);
  const d = sub(p, camera.eye);
  const half = camera.orthographic ? camera.height / 2 : dot(d, forward) * Math.tan((camera.fov * Math.PI) / 360);
  return [width / 2 + (dot(d, right) / half) * (height / 2), height / 2 - (dot(d, up) / half) * (height / 2)];
}

// The 8 corners of a box {min, max}.
export const boxCorners = ({ min, max }) => [0, 1, 2, 3, 4, 5, 6, 7].map((i) => [i & 1 ? max[0] : min[0], i & 2 ? max[1] : min[1], i & 4 ? max[2] : min[2]]);

// How `points` sit in a view {camera, width, height}: inside (every one in the image) and fill
// (their extent's share of the image along the axis where it is largest).
export function framing({ camera, width, height }, points) {
  const pixels = points.map((p) => project(camera, width, height, p));
  const xs = pixels.map((p) => p[0]), ys = pixels.map((p) => p[1]);
  const inside = pixels.every(([x, y]) => x >= 0 && x <= width && y >= 0 && y <= height);
  const fill = Math.max((Math.max(...xs) - Math.min(...xs)) / width, (Math.max(...ys) - Math.min(...ys)) / height);
  return { inside, fill, pixels };
}
