# A transient series on a grid of tets, for bench/time_play.sh: a k^3 grid of cubes, 5 tets
# each (5 k^3 tets; k = 59: 1,026,895), written as one VTK legacy binary file a step with a
# scalar "pressure" (a wave travelling along x) and a vector "velocity" (a vortex turning with
# time), and a .pvd naming the steps (times 0, 0.1, ...).
#   python3 bench/make_series.py K STEPS OUTDIR
import os
import sys

import numpy as np


def grid_tets(k):
    n = k + 1
    ids = np.arange(n ** 3).reshape(n, n, n)  # [i, j, l] -> (i * n + j) * n + l
    i, j, l = [a.ravel() for a in np.meshgrid(np.arange(k), np.arange(k), np.arange(k), indexing="ij")]
    c = np.stack([ids[i, j, l], ids[i + 1, j, l], ids[i + 1, j + 1, l], ids[i, j + 1, l],
                  ids[i, j, l + 1], ids[i + 1, j, l + 1], ids[i + 1, j + 1, l + 1], ids[i, j + 1, l + 1]], 1)
    odd = ((i + j + l) % 2 == 1)[:, None]
    even_split = [[0, 1, 2, 5], [0, 2, 3, 7], [0, 4, 5, 7], [2, 5, 6, 7], [0, 2, 5, 7]]
    odd_split = [[0, 1, 3, 4], [1, 2, 3, 6], [1, 4, 5, 6], [3, 4, 6, 7], [1, 3, 4, 6]]
    return np.concatenate([np.where(odd, c[:, b], c[:, a]) for a, b in zip(even_split, odd_split)])


def write_vtk(path, points, tets, pressure, velocity):
    with open(path, "wb") as f:
        f.write(b"# vtk DataFile Version 3.0\ntransient series step\nBINARY\nDATASET UNSTRUCTURED_GRID\n")
        f.write(b"POINTS %d float\n" % len(points))
        f.write(points.astype(">f4").tobytes())
        f.write(b"\nCELLS %d %d\n" % (len(tets), 5 * len(tets)))
        cells = np.hstack([np.full((len(tets), 1), 4), tets]).astype(">i4")
        f.write(cells.tobytes())
        f.write(b"\nCELL_TYPES %d\n" % len(tets))
        f.write(np.full(len(tets), 10, dtype=">i4").tobytes())
        f.write(b"\nPOINT_DATA %d\nSCALARS pressure float 1\nLOOKUP_TABLE default\n" % len(points))
        f.write(pressure.astype(">f4").tobytes())
        f.write(b"\nVECTORS velocity float\n")
        f.write(velocity.astype(">f4").tobytes())
        f.write(b"\n")


def main(k, steps, out):
    os.makedirs(out, exist_ok=True)
    g = np.linspace(0.0, 1.0, k + 1)
    x, y, z = [a.ravel() for a in np.meshgrid(g, g, g, indexing="ij")]
    points = np.stack([x, y, z], 1)
    tets = grid_tets(k)
    pvd = ['<?xml version="1.0"?>', '<VTKFile type="Collection" version="0.1">', "  <Collection>"]
    for s in range(steps):
        t = 0.1 * s
        pressure = np.sin(8 * (x - t)) * np.exp(-4 * ((y - 0.5) ** 2 + (z - 0.5) ** 2))
        angle = 2 * np.pi * t
        velocity = np.stack([-(y - 0.5) * np.cos(angle), (x - 0.5) * np.cos(angle), 0.3 * np.sin(angle) * z], 1)
        name = "step_%03d.vtk" % s
        write_vtk(os.path.join(out, name), points, tets, pressure, velocity)
        pvd.append('    <DataSet timestep="%g" part="0" file="%s"/>' % (t, name))
    pvd += ["  </Collection>", "</VTKFile>"]
    with open(os.path.join(out, "series.pvd"), "w") as f:
        f.write("\n".join(pvd) + "\n")
    print("%d steps of %d tets, %d vertices in %s" % (steps, len(tets), len(points), out))


if __name__ == "__main__":
    main(int(sys.argv[1]), int(sys.argv[2]), sys.argv[3])
