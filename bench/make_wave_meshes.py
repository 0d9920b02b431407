#!/usr/bin/python3
"""Meshes with oscillatory fields for the sampler comparison (bench/simplify_sample_compare.sh).

  make_wave_meshes.py cube OUT.vtk --cells N --modes K --seed S
      the unit cube as an N^3 grid of hexes (interior vertices jittered by up to 20% of a cell,
      from the seed), 6 tets a hex (Kuhn split, conforming), with K scalar fields
      mode_i = sin(a pi x) sin(b pi y) sin(c pi z): Laplace eigenmodes of the cube, the wave
      numbers a, b, c in 1..6 drawn from the seed.
  make_wave_meshes.py wave IN.vtk OUT.vtk --seed S
      IN's mesh and fields, plus a scalar `wave` = sin(k.x + phi) cos(k'.x) with |k| and |k'|
      of 3 to 6 periods over IN's bounding box diagonal, directions and phase from the seed.

Deterministic: same arguments, same bytes. Needs numpy and ../shared/data/make/tetvtk.py.
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "data", "make"))
sys.path.insert(0, "/work/shared/data/make")
import tetvtk  # noqa: E402

# Kuhn subdivision of the unit cube: 6 tets along the diagonal 0-7, corners as bit masks (x=1, y=2, z=4)
KUHN = [(0, 1, 3, 7), (0, 1, 5, 7), (0, 2, 3, 7), (0, 2, 6, 7), (0, 4, 5, 7), (0, 4, 6, 7)]


def cube(n, modes, seed):
    rng = np.random.default_rng(seed)
    g = np.linspace(0.0, 1.0, n + 1)
    x, y, z = np.meshgrid(g, g, g, indexing="ij")
    pts = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    idx = np.arange((n + 1) ** 3).reshape(n + 1, n + 1, n + 1)
    inner = np.zeros_like(x, dtype=bool)
    inner[1:-1, 1:-1, 1:-1] = True
    jitter = rng.uniform(-0.2, 0.2, size=pts.shape) / n
    pts[inner.ravel()] += jitter[inner.ravel()]
    base = idx[:-1, :-1, :-1].ravel()
    corner = [base + (c & 1) * (n + 1) ** 2 + ((c >> 1) & 1) * (n + 1) + ((c >> 2) & 1) for c in range(8)]
    tets = np.concatenate([np.stack([corner[a], corner[b], corner[c], corner[d]], axis=1) for a, b, c, d in KUHN])
    vol = np.einsum("ij,ij->i", np.cross(pts[tets[:, 1]] - pts[tets[:, 0]], pts[tets[:, 2]] - pts[tets[:, 0]]), pts[tets[:, 3]] - pts[tets[:, 0]])
    tets[vol < 0] = tets[vol < 0][:, [0, 1, 3, 2]]
    scalars = {}
    for i in range(modes):
        a, b, c = rng.integers(1, 7, size=3)
        scalars[f"mode_{i}"] = np.sin(a * np.pi * pts[:, 0]) * np.sin(b * np.pi * pts[:, 1]) * np.sin(c * np.pi * pts[:, 2])
    return pts, tets, scalars, {}


def wave(path, seed):
    pts, tets, scalars, vectors = tetvtk.read_tet_vtk(path)
    pts = pts.astype(np.float64)
    rng = np.random.default_rng(seed)
    diag = np.linalg.norm(pts.max(0) - pts.min(0))
    def vec():
        d = rng.normal(size=3)
        return d / np.linalg.norm(d) * rng.uniform(3, 6) * 2 * np.pi / diag
    k1, k2, phi = vec(), vec(), rng.uniform(0, 2 * np.pi)
    scalars = dict(scalars)
    scalars["wave"] = np.sin(pts @ k1 + phi) * np.cos(pts @ k2)
    return pts, tets, scalars, dict(vectors)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("kind", choices=["cube", "wave"])
    p.add_argument("paths", nargs="+")
    p.add_argument("--cells", type=int, default=24)
    p.add_argument("--modes", type=int, default=10)
    p.add_argument("--seed", type=int, required=True)
    a = p.parse_args()
    if a.kind == "cube":
        pts, tets, scalars, vectors = cube(a.cells, a.modes, a.seed)
    else:
        pts, tets, scalars, vectors = wave(a.paths[0], a.seed)
    out = a.paths[-1]
    tetvtk.write_tet_vtk(out, pts, tets, scalars=scalars, vectors=vectors, title=f"make_wave_meshes {a.kind} seed {a.seed}")
    print(f"{out}: {len(pts)} points, {len(tets)} tets, fields {sorted(scalars)}")


if __name__ == "__main__":
    main()
