"""How much of a mesh a view shows: the share of the tets (and of their volume) whose centroid lies
in the camera's view frustum, in front of the eye. Tells the fidelity cases that show part of the
mesh from those that show most of it (a view-adaptive cut can only gain on what the
view leaves out). The camera text is `tetrascope render --camera`'s (eye/target/up/fov, or
azimuth/elevation/distance about the bounds' centre, as view/src/camera.cpp resolves it).
usage: pvpython bench/view_tets.py MESH.vtk CAMERA [WxH]   (prints one JSON line)"""
import json
import math
import sys

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOLegacy import vtkUnstructuredGridReader

AZIMUTH_CAMERA_DISTANCE = 1.6  # lod/include/tetrascope/lod/view.h: kAzimuthCameraDistance


def camera(text, lo, hi):
    items, keys = {}, []
    for part in text.split(","):
        if part == "ortho":
            raise SystemExit("view_tets.py: orthographic cameras are not modelled")
        if part == "perspective" or not part:
            continue
        if "=" in part:
            k, v = part.split("=", 1)
            items[k] = [float(v)]
            keys.append(k)
        elif keys:
            items[keys[-1]].append(float(part))
    fov = items.get("fov", [30.0])[0]
    centre = (lo + hi) / 2
    if "eye" in items:  # lod::Camera's defaults: target at the origin, y up
        eye, target = np.array(items["eye"]), np.array(items.get("target", [0.0, 0.0, 0.0]))
        up = np.array(items.get("up", [0.0, 1.0, 0.0]))
    else:
        az = math.radians(items.get("azimuth", [30.0])[0])
        el = math.radians(items.get("elevation", [20.0])[0])
        d = items.get("distance", [AZIMUTH_CAMERA_DISTANCE])[0] * np.linalg.norm(hi - lo)
        target = np.array(items["target"]) if "target" in items else centre
        eye = target + d * np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
        up = np.array([0.0, 1.0, 0.0]) if abs(math.sin(el)) > 0.999 else np.array([0.0, 0.0, 1.0])
    return eye, target, up, fov


def main():
    mesh, text = sys.argv[1], sys.argv[2]
    w, h = (int(x) for x in (sys.argv[3] if len(sys.argv) > 3 else "256x192").split("x"))
    reader = vtkUnstructuredGridReader()
    reader.SetFileName(mesh)
    reader.ReadAllScalarsOn()
    reader.Update()
    grid = reader.GetOutput()
    points = vtk_to_numpy(grid.GetPoints().GetData()).astype(np.float64)
    cells = vtk_to_numpy(grid.GetCells().GetConnectivityArray()).astype(np.int64)
    offsets = vtk_to_numpy(grid.GetCells().GetOffsetsArray()).astype(np.int64)
    if not np.all(np.diff(offsets) == 4):
        raise SystemExit(f"{mesh}: only tetrahedra are read here")
    tets = points[cells.reshape(-1, 4)]
    centroid = tets.mean(axis=1)
    e1, e2, e3 = tets[:, 1] - tets[:, 0], tets[:, 2] - tets[:, 0], tets[:, 3] - tets[:, 0]
    volume = np.abs(np.einsum("ij,ij->i", e1, np.cross(e2, e3))) / 6
    lo, hi = points.min(axis=0), points.max(axis=0)
    eye, target, up, fov = camera(text, lo, hi)
    forward = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, forward)
    half_h = math.tan(math.radians(fov) / 2)
    half_w = half_h * w / h
    d = centroid - eye
    z = d @ forward
    front = z > 0
    zs = np.where(front, z, 1)
    inside = front & (np.abs(d @ right) / zs <= half_w) & (np.abs(d @ true_up) / zs <= half_h)
    print(json.dumps({"mesh": mesh, "camera": text, "tets": int(len(tets)), "tets_in_view": int(inside.sum()),
                      "tet_share_in_view": round(float(inside.mean()), 4),
                      "volume_share_in_view": round(float(volume[inside].sum() / volume.sum()), 4),
                      "eye_inside_bounds": bool(np.all(eye >= lo) and np.all(eye <= hi))}))


main()
