#!/usr/bin/python3
"""A real stress field: a deep beam on two pads under a load on its top, solved by FreeFem++.

Writes the beam's tet mesh (Medit .mesh: the box L x W x H in nx x ny x nz cubes, six tets
each, boundary triangles labelled 1 on the two support pads under the ends, 2 on the load pad
in the middle of the top, 3 elsewhere), runs `FreeFem++ -nw bench/freefem_beam.edp` (linear
elasticity, steel, P1 displacements, the stress projected onto P1 at the vertices) and keeps its
legacy VTK (VECTORS displacement, TENSORS stress in MPa) with a provenance file beside it
(OUT.json: the FreeFem++ version, the script, the geometry, material, load, mesh and solve
time). Without FreeFem++ (Debian: apt-get install freefem++) it says so and exits 0.

    bench/freefem_beam.py OUT.vtk [--cells 60,10,10] [--size 6,1,1] [--pad 0.4] [--load 10]
"""
import argparse
import datetime
import hashlib
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
KUHN = [(0, 1, 3, 7), (0, 1, 5, 7), (0, 2, 3, 7), (0, 2, 6, 7), (0, 4, 5, 7), (0, 4, 6, 7)]


def beam_mesh(path, cells, size, pad):
    nx, ny, nz = cells
    L, W, H = size
    gx, gy, gz = (np.linspace(0, s, n + 1) for s, n in zip(size, cells))
    z, y, x = np.meshgrid(gz, gy, gx, indexing="ij")
    points = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    vid = lambda i, j, k: (k * (ny + 1) + j) * (nx + 1) + i
    i, j, k = (a.ravel() for a in np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij"))
    corner = [vid(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1)) for c in range(8)]
    tets = np.concatenate([np.stack([corner[a], corner[b], corner[c], corner[d]], axis=1) for a, b, c, d in KUHN])
    # positive volume, as Medit expects
    p = points[tets]
    vol = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
    tets[vol < 0, 2], tets[vol < 0, 3] = tets[vol < 0, 3], tets[vol < 0, 2].copy()
    # boundary triangles: faces used by one tet
    faces = np.concatenate([tets[:, [0, 1, 2]], tets[:, [0, 1, 3]], tets[:, [0, 2, 3]], tets[:, [1, 2, 3]]])
    key = np.sort(faces, axis=1)
    _, index, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    boundary = faces[index[counts == 1]]
    c = points[boundary].mean(axis=1)
    label = np.full(len(boundary), 3)
    eps = 1e-9 * max(size)
    label[(c[:, 2] < eps) & ((c[:, 0] < pad) | (c[:, 0] > L - pad))] = 1
    label[(c[:, 2] > H - eps) & (np.abs(c[:, 0] - L / 2) < pad)] = 2
    with open(path, "w") as f:
        f.write("MeshVersionFormatted 1\nDimension 3\n")
        f.write(f"Vertices\n{len(points)}\n")
        np.savetxt(f, np.hstack([points, np.zeros((len(points), 1))]), fmt="%.9g %.9g %.9g %d")
        f.write(f"Tetrahedra\n{len(tets)}\n")
        np.savetxt(f, np.hstack([tets + 1, np.ones((len(tets), 1), dtype=int)]), fmt="%d")
        f.write(f"Triangles\n{len(boundary)}\n")
        np.savetxt(f, np.hstack([boundary + 1, label[:, None]]), fmt="%d")
        f.write("End\n")
    return len(points), len(tets), {int(l): int((label == l).sum()) for l in (1, 2, 3)}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("output")
    ap.add_argument("--cells", default="60,10,10")
    ap.add_argument("--size", default="6,1,1")
    ap.add_argument("--pad", type=float, default=0.4, help="length of each pad along the beam (support pads at both ends, the load pad centred)")
    ap.add_argument("--load", type=float, default=10.0, help="pressure on the load pad, MPa")
    a = ap.parse_args()
    freefem = shutil.which("FreeFem++")
    if not freefem:
        print("FreeFem++ is not installed (Debian: apt-get install freefem++): no stress field made")
        return 0
    cells = [int(v) for v in a.cells.split(",")]
    size = [float(v) for v in a.size.split(",")]
    if len(cells) != 3 or len(size) != 3 or min(cells) < 1 or max(cells) > 400 or min(size) <= 0 or not 0 < a.pad < size[0] / 3:
        sys.exit("--cells n,n,n (1..400), --size L,W,H (> 0), --pad below a third of L")
    out = Path(a.output)
    mesh = out.with_suffix(".mesh")
    vertices, tets, labels = beam_mesh(mesh, cells, size, a.pad)
    script = ROOT / "bench" / "freefem_beam.edp"
    start = time.perf_counter()
    run = subprocess.run([freefem, "-nw", str(script), "-mesh", str(mesh), "-out", str(out), "-load", str(a.load)], capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if run.returncode != 0 or not out.exists():
        sys.exit(f"FreeFem++ failed ({run.returncode}):\n{run.stdout[-2000:]}\n{run.stderr[-2000:]}")
    provenance = {
        "made_by": "bench/freefem_beam.py with bench/freefem_beam.edp", "date": datetime.date.today().isoformat(),
        "solver": next((line.strip(" -") for line in run.stdout.splitlines() if "FreeFem++ v" in line), "FreeFem++"),
        "script_sha256": hashlib.sha256(script.read_bytes()).hexdigest(),
        "geometry": {"box": size, "cells": cells, "pads": a.pad, "supports": "two pads under the ends of the bottom, held (u = 0)", "load": f"{a.load} MPa on the top pad, downwards"},
        "material": {"E_MPa": 210000, "nu": 0.3}, "elements": "P1 displacements; stress projected onto P1 (L2)",
        "mesh": {"vertices": vertices, "tets": tets, "boundary_triangles_by_label": labels},
        "freefem_seconds": round(seconds, 2), "freefem_output": [line for line in run.stdout.splitlines() if line.startswith("wrote ")],
    }
    out.with_suffix(".json").write_text(json.dumps(provenance, indent=1) + "\n")
    mesh.unlink()
    print(f"{out}: {vertices} vertices, {tets} tets, FreeFem++ {seconds:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
