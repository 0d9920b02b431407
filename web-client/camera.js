// Orbit / pan / zoom camera about a target, as the server's camera.set takes it; view presets.
const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => scale(a, 1 / (Math.hypot(...a) || 1));

function rotate(v, axis, angle) {  // Rodrigues
  const k = norm(axis);
  const c = Math.cos(angle), s = Math.sin(angle);
  return add(add(scale(v, c), scale(cross(k, v), s)), scale(k, dot(k, v) * (1 - c)));
}

export class OrbitCamera {
  constructor(view) {
    this.set(view);
  }

  set(view) {
    this.eye = [...view.eye];
    this.target = [...view.target];
    this.up = [...(view.up ?? [0, 1, 0])];
    this.fov = view.fov ?? 30;
    this.orthographic = !!view.orthographic;
  }

  // camera.set's fields; a parallel projection shows the height the perspective view shows
  // at the target, so switching keeps the target's scale and zooming moves the eye in both
  get() {
    const view = { eye: [...this.eye], target: [...this.target], up: [...this.up], fov: this.fov };
    if (this.orthographic) Object.assign(view, { orthographic: true, height: this.visibleHeight() });
    return view;
  }

  visibleHeight() {
    return 2 * Math.hypot(...sub(this.eye, this.target)) * Math.tan((this.fov * Math.PI) / 360);
  }

  // dx, dy: fractions of the view's height
  orbit(dx, dy) {
    let offset = sub(this.eye, this.target);
    offset = rotate(offset, this.up, -dx * Math.PI);
    const sideNow = norm(cross(this.up, offset));
    const tilted = rotate(offset, sideNow, -dy * Math.PI);
    // stop short of the poles so up stays meaningful
    if (Math.abs(dot(norm(tilted), norm(this.up))) < 0.995) offset = tilted;
    this.eye = add(this.target, offset);
  }

  pan(dx, dy) {
    const offset = sub(this.eye, this.target);
    const height = this.visibleHeight();
    // screen right is forward x up with forward = -offset; the image follows the cursor
    // when the caller passes the drag negated (the camera moves against the hand)
    const right = norm(cross(this.up, offset));
    const upScreen = norm(cross(offset, right));
    const move = add(scale(right, dx * height), scale(upScreen, -dy * height));
    this.eye = add(this.eye, move);
    this.target = add(this.target, move);
  }

  // Looks along `direction` at `target` from `distance` (view presets: ±X, ±Y, ±Z, isometric).
  look(direction, up, target, distance) {
    const d = norm(direction);
    this.target = [...target];
    this.eye = add(target, scale(d, -distance));
    this.up = Math.abs(dot(norm(up), d)) > 0.999 ? (Math.abs(d[1]) < 0.9 ? [0, 1, 0] : [0, 0, 1]) : [...up];
  }

  // The camera's frame: right, up (on screen) and forward, unit vectors in world space.
  basis() {
    const offset = sub(this.eye, this.target);
    const forward = norm(scale(offset, -1));
    const right = norm(cross(forward, this.up));
    return { right, up: cross(right, forward), forward };
  }

  zoom(factor) {
    const offset = sub(this.eye, this.target);
    const distance = Math.hypot(...offset);
    const next = Math.min(Math.max(distance * factor, 1e-6), 1e9);
    this.eye = add(this.target, scale(offset, next / distance));
    return next / distance;
  }

  // Zooms by `factor` keeping the point under the cursor where it is: (sx, sy) is the cursor's
  // offset from the view's centre in view heights (x right, y down). Exact for the plane
  // through the target facing the camera, in both projections: that plane's scale changes by
  // 1/factor about the cursor instead of the centre.
  zoomAt(factor, sx, sy) {
    const applied = this.zoom(factor);
    this.pan((sx * (1 - applied)) / applied, (sy * (1 - applied)) / applied);
  }

  // Makes `point` the rotation centre: the view slides sideways (its direction kept) until the
  // point is in the middle, so orbit and zoom turn about it. Perspective keeps the point's
  // scale on the screen (the new distance is its depth); parallel keeps the visible height.
  centreOn(point) {
    const { forward } = this.basis();
    const depth = dot(sub(point, this.eye), forward);
    const distance = this.orthographic || !(depth > 1e-9) ? Math.hypot(...sub(this.eye, this.target)) : depth;
    this.target = [...point];
    this.eye = sub(point, scale(forward, distance));
  }

  // Frames `points` (world positions, e.g. the corners of what is visible) along the current
  // view direction: the target goes to the middle of their extent on the screen plane and the
  // distance makes the extent fill the view (`aspect` = width / height; `margin` > 1 leaves
  // room around them). Perspective takes each point's depth into account.
  fit(points, aspect, margin = 1.1) {
    if (!points.length) return;
    const { right, up, forward } = this.basis();
    const project = (p) => [dot(p, right), dot(p, up), dot(p, forward)];
    const projected = points.map(project);
    const lo = [0, 1, 2].map((k) => Math.min(...projected.map((p) => p[k])));
    const hi = [0, 1, 2].map((k) => Math.max(...projected.map((p) => p[k])));
    const middle = [0, 1, 2].map((k) => (lo[k] + hi[k]) / 2);
    const centre = add(add(scale(right, middle[0]), scale(up, middle[1])), scale(forward, middle[2]));
    const tanHalf = Math.tan((this.fov * Math.PI) / 360);
    // the distance from the centre at which each point lies inside the view's frustum
    let distance = 1e-6;
    for (const p of projected) {
      const x = Math.abs(p[0] - middle[0]) * margin, y = Math.abs(p[1] - middle[1]) * margin, z = p[2] - middle[2];
      const need = this.orthographic ? Math.max(x / aspect, y) / tanHalf : Math.max(x / (aspect * tanHalf), y / tanHalf) - z;
      distance = Math.max(distance, need);
    }
    this.target = centre;
    this.eye = sub(centre, scale(forward, distance));
  }
}
