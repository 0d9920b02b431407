#!/usr/bin/python3
"""Von Mises stress derived from a tensor field against its closed form.

The field is Lamé's thick-walled cylinder under internal pressure (plane strain): inner
radius a = 1, outer b = 2, pressure p = 100, Poisson's ratio 0.3, on a quarter of the wall
(r in [1, 2], θ in [0, π/2], z in [0, 1]) meshed as hexahedra split into 6 tets each. The
stress tensor is written at the vertices in Cartesian components (VTK TENSORS, 3x3, float)
beside the analytic von Mises stress at each vertex (`von_mises_exact`).

    σrr = A - B/r², σθθ = A + B/r², σzz = 2νA, A = p a²/(b² - a²), B = p a² b²/(b² - a²)

tetrascope reads the tensor, derives `stress.von_mises`, and writes the mesh back
(`simplify --ratio 1`: every vertex kept; `--ratio 0.1`: 10% of the tets, tensors
interpolated and von Mises recomputed from them). The figures are the largest and mean
differences against the closed form at each output vertex, for the derived scalar and, in
the simplified mesh, for the exact scalar carried through the same interpolation.

    bench/tensor_lame.py [TETRASCOPE] [OUT_DIR]      writes bench/results/tensor_lame.json
"""
import json
import math
import os
import struct
import subprocess
import sys
import time

import numpy as np

A_IN, B_OUT, PRESSURE, NU = 1.0, 2.0, 100.0, 0.3
COEF_A = PRESSURE * A_IN**2 / (B_OUT**2 - A_IN**2)
COEF_B = PRESSURE * A_IN**2 * B_OUT**2 / (B_OUT**2 - A_IN**2)


def lame(x, y):
    """Cartesian stress components (xx, yy, zz, xy) and von Mises at points (x, y)."""
    r2 = x * x + y * y
    srr, stt, szz = COEF_A - COEF_B / r2, COEF_A + COEF_B / r2, np.full_like(r2, 2 * NU * COEF_A)
    c2, s2, cs = x * x / r2, y * y / r2, x * y / r2
    sxx, syy, sxy = srr * c2 + stt * s2, srr * s2 + stt * c2, (srr - stt) * cs
    vm = np.sqrt(0.5 * ((srr - stt) ** 2 + (stt - szz) ** 2 + (szz - srr) ** 2))
    return sxx, syy, szz, sxy, vm


def write_mesh(path, nr=24, nt=36, nz=8):
    r = np.linspace(A_IN, B_OUT, nr + 1)
    t = np.linspace(0, math.pi / 2, nt + 1)
    z = np.linspace(0, 1, nz + 1)
    R, T, Z = np.meshgrid(r, t, z, indexing="ij")
    x, y, zz = (R * np.cos(T)).ravel(), (R * np.sin(T)).ravel(), Z.ravel()
    at = lambda i, j, k: (i * (nt + 1) + j) * (nz + 1) + k
    tets = []
    for i in range(nr):
        for j in range(nt):
            for k in range(nz):
                c = [at(i + (q & 1), j + (q >> 1 & 1), k + (q >> 2 & 1)) for q in range(8)]
                # Kuhn split of the cube along its 0-7 diagonal: conforming between cells
                for p in ((1, 3), (1, 5), (2, 3), (2, 6), (4, 5), (4, 6)):
                    tets.append((c[0], c[p[0]], c[p[1]], c[7]))
    sxx, syy, szz, sxy, vm = lame(x, y)
    n = len(x)
    lines = ["# vtk DataFile Version 3.0", "Lame cylinder", "ASCII", "DATASET UNSTRUCTURED_GRID", f"POINTS {n} double"]
    lines += [f"{a:.17g} {b:.17g} {c:.17g}" for a, b, c in zip(x, y, zz)]
    lines += [f"CELLS {len(tets)} {5 * len(tets)}"] + [f"4 {a} {b} {c} {d}" for a, b, c, d in tets]
    lines += [f"CELL_TYPES {len(tets)}"] + ["10"] * len(tets)
    lines += [f"POINT_DATA {n}", "SCALARS von_mises_exact double 1", "LOOKUP_TABLE default"] + [f"{v:.17g}" for v in vm]
    lines += ["TENSORS stress double"]
    lines += [f"{a:.17g} {d:.17g} 0 {d:.17g} {b:.17g} 0 0 0 {c:.17g}" for a, b, c, d in zip(sxx, syy, szz, sxy)]
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    return n, len(tets)


def read_vtk_binary(path):
    """Points and point arrays of a VTK legacy BINARY file as tetrascope writes it."""
    data = open(path, "rb").read()
    pos = 0

    def line():
        nonlocal pos
        end = data.index(b"\n", pos)
        text = data[pos:end].decode()
        pos = end + 1
        return text

    def floats(count, kind=">f4"):
        nonlocal pos
        size = np.dtype(kind).itemsize * count
        out = np.frombuffer(data, dtype=kind, count=count, offset=pos).astype(np.float64)
        pos += size
        return out

    arrays, points, n = {}, None, 0
    while pos < len(data):
        words = line().split()
        if not words:
            continue
        key = words[0]
        if key == "POINTS":
            n = int(words[1])
            points = floats(3 * n).reshape(n, 3)
        elif key == "CELLS":
            floats(int(words[2]), ">i4")
        elif key == "CELL_TYPES":
            floats(int(words[1]), ">i4")
        elif key == "SCALARS":
            line()  # LOOKUP_TABLE
            arrays[words[1]] = floats(n)
        elif key in ("VECTORS", "TENSORS6"):
            arrays[words[1]] = floats((3 if key == "VECTORS" else 6) * n)
        elif key == "FIELD":
            for _ in range(int(words[2])):
                name, comps, tuples, _type = line().split()
                arrays[name] = floats(int(comps) * int(tuples))
    return points, arrays


def errors(points, arrays):
    exact = lame(points[:, 0], points[:, 1])[4]
    derived = np.abs(arrays["stress.von_mises"] - exact)
    carried = np.abs(arrays["von_mises_exact"] - exact)
    return {"vertices": len(points), "derived_max_abs_error": float(derived.max()), "derived_mean_abs_error": float(derived.mean()),
            "carried_scalar_max_abs_error": float(carried.max()), "carried_scalar_mean_abs_error": float(carried.mean()),
            "von_mises_range": [float(exact.min()), float(exact.max())]}


def main():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    binary = sys.argv[1] if len(sys.argv) > 1 else os.path.join(root, "build/release/apps/tetrascope")
    out = sys.argv[2] if len(sys.argv) > 2 else os.path.join(root, "bench/out/tensor_lame")
    os.makedirs(out, exist_ok=True)
    mesh = os.path.join(out, "lame.vtk")
    vertices, tets = write_mesh(mesh)
    result = {"field": "Lame thick-walled cylinder, a=1 b=2 p=100 nu=0.3, plane strain; quarter wall", "vertices": vertices, "tetrahedra": tets,
              "binary": binary, "date": time.strftime("%Y-%m-%d"), "runs": {}}
    info = json.loads(subprocess.run([binary, "info", "--json", mesh], check=True, capture_output=True, text=True).stdout)
    attributes = {a["name"]: a for a in info["attributes"]}
    result["info"] = {"stress_kind": attributes["stress"]["kind"], "positive_semidefinite": attributes["stress"]["tensor"]["positive_semidefinite"],
                      "derived": sorted(n for n, a in attributes.items() if a.get("kind") == "derived"), "read_seconds": info["read_seconds"]}
    for ratio in ("1", "0.1"):
        written = os.path.join(out, f"ratio-{ratio}.vtk")
        start = time.time()
        run = subprocess.run([binary, "simplify", mesh, "-o", written, "--method", "qem", "--ratio", ratio, "--json"], check=True, capture_output=True, text=True)
        seconds = time.time() - start
        points, arrays = read_vtk_binary(written)
        result["runs"][ratio] = {**errors(points, arrays), "simplify_seconds": round(seconds, 3), "tets": json.loads(run.stdout).get("tets_after")}
    path = os.path.join(root, "bench/results/tensor_lame.json")
    with open(path, "w") as f:
        json.dump(result, f, indent=2)
        f.write("\n")
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
