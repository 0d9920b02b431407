"""Times ParaView/VTK's own reader on one file (run with pvpython): prints one JSON line.
Only reader.Update() is timed; every point array is read, as tetrascope does."""
import json
import sys
import time

from vtkmodules.vtkIOLegacy import vtkUnstructuredGridReader
from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader

path = sys.argv[1]
if path == "--baseline":  # interpreter + VTK import only, for the RSS baseline
    print(json.dumps({"seconds": 0}))
    sys.exit(0)
if path.endswith(".vtu"):
    reader = vtkXMLUnstructuredGridReader()
else:
    reader = vtkUnstructuredGridReader()
    reader.ReadAllScalarsOn()
    reader.ReadAllVectorsOn()
    reader.ReadAllFieldsOn()
reader.SetFileName(path)
start = time.perf_counter()
reader.Update()
seconds = time.perf_counter() - start
grid = reader.GetOutput()
print(json.dumps({"seconds": seconds, "vertices": grid.GetNumberOfPoints(), "cells": grid.GetNumberOfCells(),
                  "arrays": grid.GetPointData().GetNumberOfArrays()}))
