// What the view can show, as points to frame ("fit what is visible", view presets): the
// corners of the dataset's box cut by the clip planes (the kept region n.x <= offset, or
// >= with invert, as clip.set keeps it). The corners of a convex polytope given by half-spaces
// are the points where three of its planes meet and every half-space holds; 6 box faces and at
// most 6 clips make at most 220 triples. Plain module: runs in the browser and under node.

const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];

// The point where the planes n.x = d of three half-spaces meet (Cramer's rule); null when two
// are parallel.
function meet(a, b, c) {
  const bc = cross(b.normal, c.normal), det = dot(a.normal, bc);
  if (Math.abs(det) < 1e-12) return null;
  const ca = cross(c.normal, a.normal), ab = cross(a.normal, b.normal);
  return [0, 1, 2].map((k) => (a.offset * bc[k] + b.offset * ca[k] + c.offset * ab[k]) / det);
}

// bounds: {min, max}; clips: [{normal, offset, invert}]. Returns the corners of the box's part
// kept by every clip (empty when the clips keep nothing of it).
export function visibleCorners(bounds, clips = []) {
  if (!bounds?.min || !bounds?.max) return [];
  const size = Math.max(...bounds.max.map((v, k) => v - bounds.min[k]), 1e-30);
  const halfSpaces = [];
  for (let k = 0; k < 3; ++k) {
    const axis = [0, 0, 0];
    axis[k] = 1;
    halfSpaces.push({ normal: axis, offset: bounds.max[k] }, { normal: axis.map((v) => -v), offset: -bounds.min[k] });
  }
  for (const clip of clips) {
    const length = Math.hypot(...clip.normal);
    if (!(length > 0)) continue;
    const sign = clip.invert ? -1 : 1;
    halfSpaces.push({ normal: clip.normal.map((v) => (sign * v) / length), offset: (sign * clip.offset) / length });
  }
  const tolerance = size * 1e-9;
  const corners = [];
  for (let i = 0; i < halfSpaces.length; ++i)
    for (let j = i + 1; j < halfSpaces.length; ++j)
      for (let k = j + 1; k < halfSpaces.length; ++k) {
        const p = meet(halfSpaces[i], halfSpaces[j], halfSpaces[k]);
        if (!p || !halfSpaces.every((h) => dot(h.normal, p) <= h.offset + tolerance)) continue;
        // a corner where more than three planes meet is found once per triple: keep one
        if (!corners.some((q) => Math.abs(q[0] - p[0]) + Math.abs(q[1] - p[1]) + Math.abs(q[2] - p[2]) <= 3 * tolerance)) corners.push(p);
      }
  return corners;
}
