"""PSNR (dB, RGB) of each refinement step saved by `tetrascope loadtest --save-refinement DIR`
against the still of the same pause; run with ParaView's pvpython (its VTK reads JPEG and PNG).
usage: pvpython bench/refine_psnr.py DIR   (prints steps.json with psnr_db_vs_still added)"""
import json
import math
import sys

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOImage import vtkJPEGReader, vtkPNGReader


def read(path):
    reader = vtkPNGReader() if path.endswith(".png") else vtkJPEGReader()
    reader.SetFileName(path)
    reader.Update()
    image = reader.GetOutput()
    pixels = vtk_to_numpy(image.GetPointData().GetScalars())
    return pixels[:, :3].astype(np.float64)


d = sys.argv[1]
steps = json.load(open(d + "/steps.json"))
still = read(d + "/" + [s["file"] for s in steps if s["still"]][0])
for s in steps:
    mse = float(np.mean((read(d + "/" + s["file"]) - still) ** 2))
    s["psnr_db_vs_still"] = None if mse == 0 else 10 * math.log10(255.0 ** 2 / mse)
print(json.dumps(steps))
