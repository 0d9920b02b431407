"""Isosurfaces of a simplified tet mesh against the original's (dissertation Table 4.2), run
with pvpython. usage: iso_compare.py ORIGINAL.vtk SIMPLIFIED.vtk SCALAR [FRACTIONS...]
For each isovalue (a fraction of the original scalar's range; 0.25 0.5 0.75 by default):
the mean and the largest distance from the simplified isosurface's points to the original
isosurface (one-sided Hausdorff), both in % of the original isosurface's bounding-box diagonal.
Prints one JSON line."""
import json
import math
import sys

from vtkmodules.vtkCommonCore import vtkObject
from vtkmodules.vtkFiltersCore import vtkContourFilter
from vtkmodules.vtkFiltersGeneral import vtkDistancePolyDataFilter
from vtkmodules.vtkFiltersGeometry import vtkGeometryFilter
from vtkmodules.vtkIOLegacy import vtkUnstructuredGridReader

vtkObject.GlobalWarningDisplayOff()
original, simplified, scalar = sys.argv[1:4]
fractions = [float(f) for f in sys.argv[4:]] or [0.25, 0.5, 0.75]


def read(path):
    reader = vtkUnstructuredGridReader()
    reader.ReadAllScalarsOn()
    reader.SetFileName(path)
    reader.Update()
    grid = reader.GetOutput()
    grid.GetPointData().SetActiveScalars(scalar)
    return grid


def contour(grid, value):
    f = vtkContourFilter()
    f.SetInputData(grid)
    f.SetInputArrayToProcess(0, 0, 0, 0, scalar)
    f.SetValue(0, value)
    f.Update()
    g = vtkGeometryFilter()
    g.SetInputData(f.GetOutput())
    g.Update()
    return g.GetOutput()


a, b = read(original), read(simplified)
lo, hi = a.GetPointData().GetArray(scalar).GetRange()
rows = []
for fraction in fractions:
    value = lo + fraction * (hi - lo)
    sa, sb = contour(a, value), contour(b, value)
    row = {"fraction": fraction, "isovalue": value, "original_triangles": sa.GetNumberOfCells(), "simplified_triangles": sb.GetNumberOfCells()}
    if sa.GetNumberOfCells() and sb.GetNumberOfCells():
        x0, x1, y0, y1, z0, z1 = sa.GetBounds()
        diagonal = math.sqrt((x1 - x0) ** 2 + (y1 - y0) ** 2 + (z1 - z0) ** 2)
        d = vtkDistancePolyDataFilter()
        d.SetInputData(0, sb)
        d.SetInputData(1, sa)
        d.SignedDistanceOff()
        d.ComputeSecondDistanceOff()
        d.Update()
        distances = d.GetOutput().GetPointData().GetArray("Distance")
        values = [abs(distances.GetValue(i)) for i in range(distances.GetNumberOfTuples())]
        row["mean_percent"] = 100 * sum(values) / len(values) / diagonal
        row["hausdorff_one_sided_percent"] = 100 * max(values) / diagonal
    rows.append(row)
print(json.dumps({"scalar": scalar, "isosurfaces": rows}))
