# Cell data against ParaView 5.11, for bench/cell_data_paraview.sh. Run with pvpython.
#   pvpython cell_data_paraview.py make OUTDIR SHARED_DATA
#     writes files with cell data by ParaView's own writers: shared meshes whose point data
#     ParaView's Point Data to Cell Data turned into cell data (VTU zlib, VTK legacy binary and
#     Exodus II),
#     and a hexahedral wavelet (Clean to Grid of an image) with cell data
#   pvpython cell_data_paraview.py check FILE TETRASCOPE_VTK   (FILE: also an OpenFOAM CASE.foam
#     or a CGNS file, bench/cgns_paraview.sh)
#     reads FILE with ParaView's reader, takes its cell arrays, cell volumes (Cell Size) and
#     connectivity, forms the volume-weighted mean at each point over the volume cells in numpy
#     (the plain mean where every volume cell around a point has zero volume),
#     and compares it with the vertex values tetrascope wrote (TETRASCOPE_VTK, the file read by
#     tetrascope and written unchanged by `tetrascope simplify --ratio 1`), matching points by
#     their coordinates; also ParaView's own Cell Data to Point Data (the plain mean) against
#     tetrascope. Prints one JSON line.
import json
import os
import sys
import time

import numpy as np
from paraview import servermanager
from paraview.simple import (CellDatatoPointData, CellSize, CleantoGrid, ExodusIIWriter, GetAnimationScene, LegacyVTKReader, MergeBlocks,
                             OpenDataFile, OpenFOAMReader, PointDatatoCellData, SaveData, Wavelet)
from vtk.util.numpy_support import vtk_to_numpy

VOLUME_TYPES = {10, 11, 12, 13, 14, 42}  # tet, voxel, hexahedron, wedge, pyramid, polyhedron


def make(out, shared):
    os.makedirs(out, exist_ok=True)
    for name in ("disk_out_ref", "nasa_bluntfin"):
        source = LegacyVTKReader(FileNames=[os.path.join(shared, name + ".vtk")])
        cells = PointDatatoCellData(Input=source)
        cells.ProcessAllArrays = 1
        cells.PassPointData = 0
        SaveData(os.path.join(out, name + "_cells.vtu"), proxy=cells, CompressorType="ZLib")
        SaveData(os.path.join(out, name + "_cells.vtk"), proxy=cells, FileType="Binary")
        ExodusIIWriter(Input=cells, FileName=os.path.join(out, name + "_cells.exo")).UpdatePipeline()
    wave = Wavelet(WholeExtent=[-12, 12, -12, 12, -6, 6])
    cells = PointDatatoCellData(Input=wave)
    cells.PassPointData = 0
    grid = CleantoGrid(Input=cells)
    SaveData(os.path.join(out, "wavelet_hex_cells.vtu"), proxy=grid, CompressorType="ZLib")


def fetch(proxy):
    proxy.UpdatePipeline()
    return servermanager.Fetch(proxy)


# arrays ParaView's Exodus reader makes itself (and the element number map and block id it shows as "ids" and "object_id")
GENERATED = {"ObjectId", "GlobalElementId", "PedigreeElementId", "GlobalNodeId", "PedigreeNodeId", "ids", "object_id"}


def check(path, ours_path, at_time=None):
    """The comparison as a dict; an OpenFOAM case at `at_time` (default: its latest time)."""
    start = time.perf_counter()
    if path.endswith(".foam"):  # the internal mesh at the latest time, polyhedra kept whole
        reader = OpenFOAMReader(FileName=path)
        reader.MeshRegions = ["internalMesh"]
        reader.Decomposepolyhedra = 0
        reader.UpdatePipelineInformation()
        when = max(reader.TimestepValues) if at_time is None else at_time
        reader.UpdatePipeline(when)
        GetAnimationScene().AnimationTime = when  # what the filters below and Fetch update at
        source = MergeBlocks(Input=reader)
        source.UpdatePipeline(when)
    else:
        source = OpenDataFile(path)
        if path.endswith(".cgns"):  # ParaView's CGNS reader loads no array unless asked
            source.UpdatePipelineInformation()
            source.CellArrayStatus = source.CellArrayStatus.Available
            source.PointArrayStatus = source.PointArrayStatus.Available
        source.UpdatePipeline()
    reader_seconds = time.perf_counter() - start  # ParaView's reader alone, in this process
    if path.endswith((".exo", ".cgns")):
        source = MergeBlocks(Input=source)
    grid = fetch(source)
    points = vtk_to_numpy(grid.GetPoints().GetData()).astype(np.float32)
    n = points.shape[0]
    types = vtk_to_numpy(grid.GetCellTypesArray())
    cells = grid.GetCells()
    offsets = vtk_to_numpy(cells.GetOffsetsArray())
    connectivity = vtk_to_numpy(cells.GetConnectivityArray())
    sizes = CellSize(Input=source)
    sizes.ComputeVertexCount = 0
    sizes.ComputeLength = 0
    sizes.ComputeArea = 0
    sizes.ComputeVolume = 1
    volume = np.abs(vtk_to_numpy(fetch(sizes).GetCellData().GetArray("Volume")).astype(np.float64))
    volume[~np.isin(types, list(VOLUME_TYPES))] = 0
    counts = np.diff(offsets)
    owner = np.repeat(np.arange(len(types)), counts)
    weights = np.bincount(connectivity, weights=volume[owner], minlength=n)
    plain = CellDatatoPointData(Input=source)
    plain_grid = fetch(plain)
    ours_grid = fetch(LegacyVTKReader(FileNames=[ours_path]))
    ours_points = vtk_to_numpy(ours_grid.GetPoints().GetData()).astype(np.float32)
    if ours_points.shape == points.shape and np.array_equal(ours_points, points):
        order = np.arange(n)  # the same points in the same order
    else:  # matched by coordinates (a point written twice matches its last copy)
        index = {tuple(p): i for i, p in enumerate(points.tolist())}
        order = np.array([index.get(tuple(p), -1) for p in ours_points.tolist()])
    result = {"file": os.path.basename(path), "points": int(n), "cells": int(len(types)),
              "paraview_reader_seconds": reader_seconds, "volume_cells": int(np.isin(types, list(VOLUME_TYPES)).sum()), "points_matched": int((order >= 0).sum()),
              "tetrascope_points": int(len(ours_points)), "points_in_zero_volume_cells_only": int(((weights == 0) & (np.bincount(connectivity, minlength=n) > 0)).sum()), "same_point_order": bool(len(order) == n and np.array_equal(order, np.arange(n))),
              "arrays": []}
    data = grid.GetCellData()
    for a in range(data.GetNumberOfArrays()):
        array = data.GetArray(a)
        if array is None or array.GetName() in GENERATED:
            continue
        name = array.GetName()
        values = vtk_to_numpy(array).astype(np.float64).reshape(len(types), -1)
        weighted = np.stack([np.bincount(connectivity, weights=(volume * values[:, k])[owner], minlength=n) for k in range(values.shape[1])], 1)
        # a vertex whose volume cells all have zero volume: their plain mean
        volume_cell = np.isin(types, list(VOLUME_TYPES)).astype(np.float64)
        plain_sum = np.stack([np.bincount(connectivity, weights=(volume_cell * values[:, k])[owner], minlength=n) for k in range(values.shape[1])], 1)
        plain_count = np.bincount(connectivity, weights=volume_cell[owner], minlength=n)
        weighted = np.where(weights[:, None] > 0, weighted / np.maximum(weights, 1e-300)[:, None],
                            np.where(plain_count[:, None] > 0, plain_sum / np.maximum(plain_count, 1)[:, None], 0))
        # a cell array named like a point array arrives as NAME_cells
        ours_array = ours_grid.GetPointData().GetArray(name + "_cells") or ours_grid.GetPointData().GetArray(name)
        if ours_array is None:
            result["arrays"].append({"name": name, "missing": True})
            continue
        ours = vtk_to_numpy(ours_array).astype(np.float64).reshape(len(ours_points), -1)[order >= 0]
        theirs = weighted[order[order >= 0]]
        scale = max(np.abs(theirs).max(), 1e-30)
        mean = vtk_to_numpy(plain_grid.GetPointData().GetArray(name)).astype(np.float64).reshape(n, -1)[order[order >= 0]]
        result["arrays"].append({"name": name, "components": int(values.shape[1]),
                                 "max_relative_difference": float(np.abs(ours - theirs).max() / scale),
                                 "paraview_plain_mean_max_relative_difference": float(np.abs(ours - mean).max() / scale),
                                 "paraview_plain_mean_median_relative_difference": float(np.median(np.abs(ours - mean)) / scale)})
    # point arrays, where the file has them: read as they are
    points_data = grid.GetPointData()
    for a in range(points_data.GetNumberOfArrays()):
        array = points_data.GetArray(a)
        if array is None or array.GetName() in GENERATED or ours_grid.GetPointData().GetArray(array.GetName()) is None:
            continue
        theirs = vtk_to_numpy(array).astype(np.float64).reshape(n, -1)[order[order >= 0]]
        ours = vtk_to_numpy(ours_grid.GetPointData().GetArray(array.GetName())).astype(np.float64).reshape(len(ours_points), -1)[order >= 0]
        result.setdefault("point_arrays", []).append({"name": array.GetName(), "max_relative_difference": float(np.abs(ours - theirs).max() / max(np.abs(theirs).max(), 1e-30))})
    return result


if __name__ == "__main__":
    if sys.argv[1] == "make":
        make(sys.argv[2], sys.argv[3])
    else:
        print(json.dumps(check(sys.argv[2], sys.argv[3])))
