"""Writes a .vtk as .vtu with ParaView/VTK's XML writer (run with pvpython).
usage: to_vtu.py IN.vtk OUT.vtu raw|zlib   (appended binary data, UInt64 headers)"""
import sys

from vtkmodules.vtkIOLegacy import vtkUnstructuredGridReader
from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridWriter

src, out, mode = sys.argv[1:4]
reader = vtkUnstructuredGridReader()
reader.ReadAllScalarsOn()
reader.ReadAllVectorsOn()
reader.SetFileName(src)
reader.Update()
writer = vtkXMLUnstructuredGridWriter()
writer.SetInputData(reader.GetOutput())
writer.SetFileName(out)
writer.SetDataModeToAppended()
writer.EncodeAppendedDataOff()
writer.SetHeaderTypeToUInt64()
if mode == "zlib":
    writer.SetCompressorTypeToZLib()
else:
    writer.SetCompressorTypeToNone()
if not writer.Write():
    sys.exit("write failed")
