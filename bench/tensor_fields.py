#!/usr/bin/python3
"""The artificial tensor fields of the dissertation's §7.4.4, written as legacy VTK with TENSORS.

Each field lives on the unit cube, N cells a side, every cube split into six tets (Kuhn), the
symmetric tensor D = l1 e1 e1^T + l2 e2 e2^T + l3 e3 e3^T given at the vertices:

  spiral      planar tensors about the z axis through the cube's centre: the minor eigenvector
              e3 is the normal of the helicoids z = z0 + C theta (C = 0.25), e1 the radial
              direction (on the helicoid), l = (1, 0.6, 0.05): cp 0.67, cl 0.24. Diffusion
              surfaces are the helicoids, the lines of e1 radial rays; within 0.02 of the axis
              (the singularity) the tensor is isotropic.
  sphere      inside radius 0.2 about the centre linear along z (l = (1, 0.1, 0.1)): the lines
              are parallel to z; outside planar with the radial direction as minor eigenvector
              (l = (1, 1, 0.05)): the surfaces are spheres about the centre, enclosing the lines.
  sinusoidal  e1 along the curves y = y0 + A sin(K x) (A = 0.1, K = 4 pi), e3 = z, the medium
              eigenvalue l2 = 0.5 - 0.4 sin(4 pi z): linear slabs (l2 = 0.1, cl 0.75) where the
              lines follow the sinusoids, planar slabs (l2 = 0.9, cp 0.8) where the surfaces are
              the planes z = const, alternating twice along z.

The exact curves and surfaces are what tests/support/tensor_fields.h checks stream tubes and
diffusion surfaces against (the same formulas).

usage: bench/tensor_fields.py spiral|sphere|sinusoidal OUT.vtk [--cells N]
"""
import argparse
import math
import sys

import numpy as np

SPIRAL_C = 0.25
SPIRAL_CORE = 0.02
SPHERE_R = 0.2
SINE_A = 0.1
SINE_K = 4 * math.pi


def unit(v):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1)


def frame_tensor(e1, e2, e3, l1, l2, l3):
    outer = lambda a, b: a[:, :, None] * b[:, None, :]
    return l1[:, None, None] * outer(e1, e1) + l2[:, None, None] * outer(e2, e2) + l3[:, None, None] * outer(e3, e3)


def spiral(p):
    x, y = p[:, 0] - 0.5, p[:, 1] - 0.5
    r2 = np.maximum(x * x + y * y, 1e-300)
    n = unit(np.stack([SPIRAL_C * y / r2, -SPIRAL_C * x / r2, np.ones_like(x)], axis=1))
    e1 = unit(np.stack([x, y, np.zeros_like(x)], axis=1))
    e2 = np.cross(n, e1)
    one = np.ones(len(p))
    d = frame_tensor(e1, e2, n, one, 0.6 * one, 0.05 * one)
    core = r2 < SPIRAL_CORE ** 2
    d[core] = np.eye(3)
    return d


def sphere(p):
    c = p - 0.5
    r = np.linalg.norm(c, axis=1)
    n = unit(np.where(r[:, None] > 0, c, [[1.0, 0, 0]]))
    one = np.ones(len(p))
    outside = np.eye(3)[None, :, :] * one[:, None, None] - 0.95 * n[:, :, None] * n[:, None, :]
    inside = np.diag([0.1, 0.1, 1.0])[None, :, :] * one[:, None, None]
    return np.where((r < SPHERE_R)[:, None, None], inside, outside)


def sinusoidal(p):
    e1 = unit(np.stack([np.ones(len(p)), SINE_A * SINE_K * np.cos(SINE_K * p[:, 0]), np.zeros(len(p))], axis=1))
    e3 = np.tile([0.0, 0.0, 1.0], (len(p), 1))
    e2 = np.cross(e3, e1)
    one = np.ones(len(p))
    return frame_tensor(e1, e2, e3, one, 0.5 - 0.4 * np.sin(4 * math.pi * p[:, 2]), 0.1 * one)


FIELDS = {"spiral": spiral, "sphere": sphere, "sinusoidal": sinusoidal}


def kuhn_cube(n):
    g = np.linspace(0.0, 1.0, n + 1)
    z, y, x = np.meshgrid(g, g, g, indexing="ij")
    points = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    vid = lambda i, j, k: (k * (n + 1) + j) * (n + 1) + i
    i, j, k = np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij")
    i, j, k = i.ravel(), j.ravel(), k.ravel()
    corner = [vid(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1)) for c in range(8)]
    # six tets about the diagonal 0-7, each a path 0 -> 7 through the cube's corners
    paths = [(1, 3), (1, 5), (2, 3), (2, 6), (4, 5), (4, 6)]
    tets = [np.stack([corner[0], corner[a], corner[b], corner[7]], axis=1) for a, b in paths]
    return points, np.concatenate(tets)


def write_vtk(path, name, points, tets, tensors):
    with open(path, "w") as f:
        f.write(f"# vtk DataFile Version 3.0\ntetrascope artificial tensor field '{name}' (bench/tensor_fields.py)\nASCII\nDATASET UNSTRUCTURED_GRID\n")
        f.write(f"POINTS {len(points)} double\n")
        np.savetxt(f, points, fmt="%.9g")
        f.write(f"CELLS {len(tets)} {5 * len(tets)}\n")
        np.savetxt(f, np.hstack([np.full((len(tets), 1), 4), tets]), fmt="%d")
        f.write(f"CELL_TYPES {len(tets)}\n")
        np.savetxt(f, np.full(len(tets), 10), fmt="%d")
        f.write(f"POINT_DATA {len(points)}\nTENSORS D double\n")
        np.savetxt(f, tensors.reshape(-1, 3), fmt="%.9g")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("field", choices=sorted(FIELDS))
    ap.add_argument("output")
    ap.add_argument("--cells", type=int, default=24, help="cells along each side (default 24: 15,625 vertices, 82,944 tets)")
    a = ap.parse_args()
    if not 1 <= a.cells <= 400:
        sys.exit("--cells must be 1 to 400")
    points, tets = kuhn_cube(a.cells)
    write_vtk(a.output, a.field, points, tets, FIELDS[a.field](points))
    print(f"{a.output}: {a.field}, {len(points)} vertices, {len(tets)} tets")


if __name__ == "__main__":
    main()
