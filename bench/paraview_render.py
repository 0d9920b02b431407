# ParaView's unstructured volume rendering ("Projected tetra") of a mesh over a camera orbit,
# for bench/render_bench.sh: the same size, attribute and camera path as `tetrascope render
# --orbit N` (azimuth 30 + 360 k / N, elevation 20, distance 1.6 box diagonals, fov 30, z up).
# Run with pvbatch under Xvfb. Prints one JSON line: first-frame and per-frame ms.
#   pvbatch paraview_render.py MESH ATTRIBUTE WIDTH HEIGHT FRAMES
import json
import math
import sys
import time

from paraview.simple import (ColorBy, CreateRenderView, GetOpacityTransferFunction, LegacyVTKReader, Render, Show)

mesh, attribute, width, height, frames = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5])
start = time.perf_counter()
reader = LegacyVTKReader(FileNames=[mesh])
reader.UpdatePipeline()
view = CreateRenderView()
view.ViewSize = [width, height]
view.OrientationAxesVisibility = 0
display = Show(reader, view)
display.SetRepresentationType("Volume")
display.SelectMapper = "Projected tetra"
ColorBy(display, ("POINTS", attribute))
lo, hi = reader.PointData[attribute].GetRange()
opacity = GetOpacityTransferFunction(attribute)
opacity.Points = [lo, 0.0, 0.5, 0.0, hi, 0.4, 0.5, 0.0]
bounds = reader.GetDataInformation().GetBounds()
centre = [(bounds[0] + bounds[1]) / 2, (bounds[2] + bounds[3]) / 2, (bounds[4] + bounds[5]) / 2]
diagonal = math.sqrt((bounds[1] - bounds[0]) ** 2 + (bounds[3] - bounds[2]) ** 2 + (bounds[5] - bounds[4]) ** 2)
view.CameraViewAngle = 30
read_s = time.perf_counter() - start


def place(k):
    az, el, d = math.radians(30 + 360.0 * k / frames), math.radians(20), 1.6 * diagonal
    view.CameraFocalPoint = centre
    view.CameraPosition = [centre[0] + d * math.cos(el) * math.cos(az), centre[1] + d * math.cos(el) * math.sin(az), centre[2] + d * math.sin(el)]
    view.CameraViewUp = [0, 0, 1]


times = []
first = None
for k in range(frames):
    place(k)
    t = time.perf_counter()
    Render(view)
    ms = (time.perf_counter() - t) * 1000
    if first is None:
        first = ms
    else:
        times.append(ms)
times.sort()
print(json.dumps({"mesh": mesh, "frames": frames, "read_s": read_s, "first_frame_ms": first,
                  "median_ms": times[len(times) // 2] if times else first, "width": width, "height": height}))
