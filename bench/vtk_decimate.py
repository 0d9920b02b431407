"""VTK's vtkUnstructuredGridQuadricDecimation on one tet mesh (run with pvpython).
usage: vtk_decimate.py IN.vtk OUT.vtk TARGET_RATIO [SCALAR]
Prints one JSON line: seconds (the filter's Update only), tets before/after."""
import json
import sys
import time

from vtkmodules.vtkCommonCore import vtkObject
from vtkmodules.vtkFiltersCore import vtkUnstructuredGridQuadricDecimation
from vtkmodules.vtkIOLegacy import vtkUnstructuredGridReader, vtkUnstructuredGridWriter

vtkObject.GlobalWarningDisplayOff()
src, out, ratio = sys.argv[1], sys.argv[2], float(sys.argv[3])
scalar = sys.argv[4] if len(sys.argv) > 4 else None
reader = vtkUnstructuredGridReader()
reader.ReadAllScalarsOn()
reader.ReadAllVectorsOn()
reader.SetFileName(src)
reader.Update()
grid = reader.GetOutput()
if scalar:
    grid.GetPointData().SetActiveScalars(scalar)
decimate = vtkUnstructuredGridQuadricDecimation()
decimate.SetInputData(grid)
decimate.SetTargetReduction(1.0 - ratio)
if scalar:
    decimate.SetScalarsName(scalar)
start = time.perf_counter()
decimate.Update()
seconds = time.perf_counter() - start
result = decimate.GetOutput()
if scalar and result.GetPointData().GetNumberOfArrays() == 1:
    result.GetPointData().GetArray(0).SetName(scalar)  # VTK calls it "scalars"
writer = vtkUnstructuredGridWriter()
writer.SetInputData(result)
writer.SetFileName(out)
writer.SetFileTypeToBinary()
writer.Write()
print(json.dumps({"seconds": seconds, "tets_before": grid.GetNumberOfCells(), "tets_after": result.GetNumberOfCells(),
                  "point_arrays": [result.GetPointData().GetArrayName(i) for i in range(result.GetPointData().GetNumberOfArrays())]}))
