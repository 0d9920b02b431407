# ParaView's Stream Tracer (vtkStreamTracer, RK4-5) on the seeds of `tetrascope streamlines
# --seeds line:...`, for bench/streamlines_bench.sh: its integration time (median of RUNS), and the
# distance between its lines and each of ours (OURS.vtk, matched by seed id), both resampled by arc length
# over their common length, relative to the local cell size (cube root of 6x the volume of the tet
# holding the sample, at least a tenth of its longest edge: tetrascope's own measure).
#   pvpython paraview_streamlines.py MESH FIELD x0,y0,z0,x1,y1,z1,N MAX_LENGTH LABEL=OURS.vtk[,LABEL=OURS2.vtk] RUNS
# Prints one JSON line.
import json
import math
import statistics
import sys
import time

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkCommonCore import vtkPoints
from vtkmodules.vtkCommonDataModel import vtkPolyData, vtkStaticCellLocator
from vtkmodules.vtkFiltersFlowPaths import vtkStreamTracer
from vtkmodules.vtkIOLegacy import vtkPolyDataReader, vtkUnstructuredGridReader

mesh_path, field, rake, max_length, ours_path, runs = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4]), sys.argv[5], int(sys.argv[6])
SAMPLES = 64  # arc-length samples per matched pair of lines

reader = vtkUnstructuredGridReader()
reader.SetFileName(mesh_path)
reader.ReadAllScalarsOn()
reader.ReadAllVectorsOn()
reader.Update()
grid = reader.GetOutput()
grid.GetPointData().SetActiveVectors(field)

v = [float(s) for s in rake.split(",")]
n = int(v[6])
points = vtkPoints()
for i in range(n):
    s = 0.0 if n == 1 else i / (n - 1)
    points.InsertNextPoint(v[0] + s * (v[3] - v[0]), v[1] + s * (v[4] - v[1]), v[2] + s * (v[5] - v[2]))
seeds = vtkPolyData()
seeds.SetPoints(points)


def trace():
    tracer = vtkStreamTracer()
    tracer.SetInputData(grid)
    tracer.SetSourceData(seeds)
    tracer.SetInputArrayToProcess(0, 0, 0, 0, field)
    tracer.SetIntegratorTypeToRungeKutta45()
    tracer.SetIntegrationDirectionToForward()
    tracer.SetMaximumPropagation(max_length)
    tracer.SetMaximumNumberOfSteps(10000)
    tracer.SetIntegrationStepUnit(vtkStreamTracer.CELL_LENGTH_UNIT)
    tracer.SetInitialIntegrationStep(0.2)
    tracer.SetMinimumIntegrationStep(0.01)
    tracer.SetMaximumIntegrationStep(0.5)
    tracer.SetMaximumError(1e-6)
    tracer.SetTerminalSpeed(1e-12)
    tracer.SetComputeVorticity(False)
    start = time.perf_counter()
    tracer.Update()
    return time.perf_counter() - start, tracer.GetOutput()


times = []
for _ in range(runs):
    seconds, theirs = trace()
    times.append(seconds)


def lines_by_seed(poly, seed_array):
    ids = vtk_to_numpy(poly.GetCellData().GetArray(seed_array)) if poly.GetNumberOfCells() else np.zeros(0)
    xyz = vtk_to_numpy(poly.GetPoints().GetData()).astype(np.float64) if poly.GetNumberOfPoints() else np.zeros((0, 3))
    out = {}
    for c in range(poly.GetNumberOfCells()):
        cell_ids = poly.GetCell(c).GetPointIds()
        idx = [cell_ids.GetId(k) for k in range(cell_ids.GetNumberOfIds())]
        if len(idx) >= 2:
            out[int(ids[c])] = xyz[idx]
    return out


def resample(line, total):
    seg = np.linalg.norm(np.diff(line, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    at = np.linspace(0.0, total, SAMPLES)
    return np.stack([np.interp(at, arc, line[:, k]) for k in range(3)], axis=1)


def arc_length(line):
    return float(np.sum(np.linalg.norm(np.diff(line, axis=0), axis=1)))


theirs_lines = lines_by_seed(theirs, "SeedIds")

locator = vtkStaticCellLocator()
locator.SetDataSet(grid)
locator.BuildLocator()
xyz = vtk_to_numpy(grid.GetPoints().GetData()).astype(np.float64)
cells = vtk_to_numpy(grid.GetCells().GetConnectivityArray()).reshape(-1, 4)


def cell_size(p):
    c = locator.FindCell(p)
    if c < 0:
        return float("nan")
    a, b, cc, d = xyz[cells[c]]
    volume = abs(np.dot(b - a, np.cross(cc - a, d - a)))
    edges = [np.linalg.norm(x - y) for x, y in ((a, b), (a, cc), (a, d), (b, cc), (b, d), (cc, d))]
    return max(volume ** (1.0 / 3.0), 0.1 * max(edges))


def compare(path):
    ours_reader = vtkPolyDataReader()
    ours_reader.SetFileName(path)
    ours_reader.ReadAllScalarsOn()
    ours_reader.Update()
    ours = lines_by_seed(ours_reader.GetOutput(), "seed_id")
    per_line_mean, overall_max, matched, length_ratio = [], 0.0, 0, []
    for seed, theirs_line in theirs_lines.items():
        if seed not in ours:
            continue
        mine = ours[seed]
        la, lb = arc_length(mine), arc_length(theirs_line)
        length_ratio.append(la / lb if lb > 0 else float("nan"))
        common = min(la, lb)
        if common <= 0:
            continue
        a, b = resample(mine, common), resample(theirs_line, common)
        rel = []
        for k in range(SAMPLES):
            h = cell_size(b[k])
            if not math.isfinite(h) or h <= 0:
                h = cell_size(a[k])
            if math.isfinite(h) and h > 0:
                rel.append(float(np.linalg.norm(a[k] - b[k])) / h)
        if rel:
            matched += 1
            per_line_mean.append(sum(rel) / len(rel))
            overall_max = max(overall_max, max(rel))
    per_line_mean.sort()
    return {
        "ours_lines": len(ours), "matched_lines": matched,
        "distance_cells_mean": sum(per_line_mean) / len(per_line_mean) if per_line_mean else None,
        "distance_cells_median_line": per_line_mean[len(per_line_mean) // 2] if per_line_mean else None,
        "distance_cells_p95_line": per_line_mean[int(0.95 * (len(per_line_mean) - 1))] if per_line_mean else None,
        "distance_cells_max": overall_max,
        "length_ratio_median": statistics.median(length_ratio) if length_ratio else None,
    }


# vtkStreamTracer::ReasonForTermination
REASONS = {1: "boundary", 2: "not_initialized", 3: "unexpected_value", 4: "max_length", 5: "max_steps", 6: "zero_velocity"}
stops = {}
reason_array = theirs.GetCellData().GetArray("ReasonForTermination")
for c in range(theirs.GetNumberOfCells() if reason_array else 0):
    name = REASONS.get(int(reason_array.GetValue(c)), str(int(reason_array.GetValue(c))))
    stops[name] = stops.get(name, 0) + 1
print(json.dumps({
    "paraview_seconds": statistics.median(times), "paraview_runs": times,
    "paraview_lines": len(theirs_lines), "paraview_points": theirs.GetNumberOfPoints(), "paraview_stops": stops,
    "against": {label: compare(path) for label, path in (item.split("=", 1) for item in ours_path.split(","))},
}))
