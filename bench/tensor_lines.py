#!/usr/bin/python3
"""Lines through a tensor field against its exact major-eigenvector curves.

The field: λ1 e1 e1ᵀ + λ2 e2 e2ᵀ + λ3 e3 e3ᵀ with λ = (3, 1, 0.5), e1 tangent to the circles
about the z axis, e2 radial, e3 = z (isotropic on the axis), at the vertices of the slab
[-1, 1]² x [0, 0.25] (a 48 x 48 x 4 grid of cubes, 6 tets each) as VTK TENSORS6. The exact
lines along e1 are circles. `tetrascope streamlines --field D` traces a rake of 8 seeds on the
x axis (r = 0.2 … 0.9) in both directions for 4 bounding-box diagonals each (several turns);
the figures are each point's distance from its seed's circle, relative to the diagonal, and
whether a line ever turns back (a lost eigenvector sign).

    bench/tensor_lines.py [TETRASCOPE] [OUT_DIR]      writes bench/results/tensor_lines.json
"""
import json
import math
import os
import subprocess
import sys
import time

import numpy as np


def write_mesh(path, n=48, nz=4):
    xs, ys, zs = np.linspace(-1, 1, n + 1), np.linspace(-1, 1, n + 1), np.linspace(0, 0.25, nz + 1)
    X, Y, Z = np.meshgrid(xs, ys, zs, indexing="ij")
    x, y, z = X.ravel(), Y.ravel(), Z.ravel()
    at = lambda i, j, k: (i * (n + 1) + j) * (nz + 1) + k
    tets = []
    for i in range(n):
        for j in range(n):
            for k in range(nz):
                c = [at(i + (q & 1), j + (q >> 1 & 1), k + (q >> 2 & 1)) for q in range(8)]
                for p in ((1, 3), (1, 5), (2, 3), (2, 6), (4, 5), (4, 6)):
                    tets.append((c[0], c[p[0]], c[p[1]], c[7]))
    r = np.hypot(x, y)
    safe = np.where(r > 1e-12, r, 1)
    e1x, e1y = np.where(r > 1e-12, -y / safe, 1), np.where(r > 1e-12, x / safe, 0)
    l1, l2, l3 = np.where(r > 1e-12, 3.0, 1.0), 1.0, np.where(r > 1e-12, 0.5, 1.0)
    e2x, e2y = -e1y, e1x
    xx, yy, xy = l1 * e1x * e1x + l2 * e2x * e2x, l1 * e1y * e1y + l2 * e2y * e2y, l1 * e1x * e1y + l2 * e2x * e2y
    lines = ["# vtk DataFile Version 3.0", "rotating tensor", "ASCII", "DATASET UNSTRUCTURED_GRID", f"POINTS {len(x)} double"]
    lines += [f"{a:.17g} {b:.17g} {c:.17g}" for a, b, c in zip(x, y, z)]
    lines += [f"CELLS {len(tets)} {5 * len(tets)}"] + [f"4 {a} {b} {c} {d}" for a, b, c, d in tets]
    lines += [f"CELL_TYPES {len(tets)}"] + ["10"] * len(tets)
    lines += [f"POINT_DATA {len(x)}", "TENSORS6 D double"]
    lines += [f"{a:.17g} {b:.17g} {c:.17g} {d:.17g} 0 0" for a, b, c, d in zip(xx, yy, np.broadcast_to(l3, x.shape), xy)]
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    return len(x), len(tets)


def read_polydata(path):
    """Points and lines of the binary POLYDATA tetrascope streamlines writes."""
    data = open(path, "rb").read()
    head = data.index(b"POINTS")
    end = data.index(b"\n", head)
    n = int(data[head:end].split()[1])
    points = np.frombuffer(data, dtype=">f4", count=3 * n, offset=end + 1).astype(np.float64).reshape(n, 3)
    at = data.index(b"LINES", end + 1 + 12 * n)
    end = data.index(b"\n", at)
    count, size = (int(v) for v in data[at:end].split()[1:3])
    ints = np.frombuffer(data, dtype=">i4", count=size, offset=end + 1)
    out, pos = [], 0
    for _ in range(count):
        k = int(ints[pos])
        out.append(ints[pos + 1:pos + 1 + k])
        pos += 1 + k
    return points, out


def main():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    binary = sys.argv[1] if len(sys.argv) > 1 else os.path.join(root, "build/release/apps/tetrascope")
    out = sys.argv[2] if len(sys.argv) > 2 else os.path.join(root, "bench/out/tensor_lines")
    os.makedirs(out, exist_ok=True)
    mesh = os.path.join(out, "rotating.vtk")
    vertices, tets = write_mesh(mesh)
    written = os.path.join(out, "lines.vtk")
    start = time.time()
    run = subprocess.run([binary, "streamlines", mesh, "--field", "D", "--seeds", "line:0.2,0,0.125,0.9,0,0.125,8", "-o", written, "--json"],
                         check=True, capture_output=True, text=True)
    seconds = time.time() - start
    report = json.loads(run.stdout)
    points, lines = read_polydata(written)
    diagonal = math.sqrt(4 + 4 + 0.0625)
    rows, turned_back = [], 0
    for line in lines:
        p = points[line]
        radius = np.hypot(p[:, 0], p[:, 1])
        seed_radius = radius[np.argmin(np.abs(p[:, 1]) + np.abs(p[:, 0] - radius))]  # the point on the +x axis
        off = np.abs(radius - seed_radius) / diagonal
        angle = np.unwrap(np.arctan2(p[:, 1], p[:, 0]))
        steps = np.diff(angle)
        turned_back += int(np.sum(steps * np.sign(angle[-1] - angle[0]) < 0))
        rows.append({"radius": round(float(seed_radius), 4), "points": int(len(line)), "turns": round(abs(float(angle[-1] - angle[0])) / (2 * math.pi), 2),
                     "mean_offset_of_diagonal": float(off.mean()), "max_offset_of_diagonal": float(off.max())})
    result = {"field": "rotating tensor, lambda (3, 1, 0.5), e1 tangent to circles about z; slab [-1,1]^2 x [0,0.25]", "vertices": vertices, "tetrahedra": tets,
              "binary": binary, "date": time.strftime("%Y-%m-%d"), "lines": rows, "steps_turning_back": turned_back,
              "mean_offset_of_diagonal": float(np.mean([r["mean_offset_of_diagonal"] for r in rows])),
              "max_offset_of_diagonal": float(np.max([r["max_offset_of_diagonal"] for r in rows])),
              "trace_seconds": report["trace_seconds"], "load_seconds": report["load_seconds"], "process_seconds": round(seconds, 3), "stops": report["stops"]}
    with open(os.path.join(root, "bench/results/tensor_lines.json"), "w") as f:
        json.dump(result, f, indent=2)
        f.write("\n")
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
