#!/usr/bin/python3
"""Tensor lines and diffusion surfaces on a 500K-tet stress field, beside ParaView's Tensor Glyph.

The field is Lamé's thick-walled cylinder under internal pressure (bench/tensor_lame.py's
quarter wall, 40 x 60 x 35 hexahedra split into 6 tets each: 504,000 tets), its stress tensor
at the vertices. In one run, each whole process timed (median of --repeat runs):

- `tetrascope streamlines --field stress --seeds dense:N --min-cl C`: lines along the major
  principal stress (the axes of §7.4.2's stream tubes);
- `tetrascope diffusion-surfaces --tensor stress --seeds dense:N`: surfaces in the planar
  regions (§7.4.3);
- ParaView's Tensor Glyph (pvpython: the legacy VTK reader, TensorGlyph with its default
  sphere glyph scaled by the eigenvalues, at every vertex), the way a ParaView user shows a
  tensor.

Writes bench/results/tensor_surfaces.json.

    bench/tensor_surfaces.py [--tetrascope BIN] [--dense 16] [--min-cl 0.3] [--repeat 3] [--work DIR]
"""
import argparse
import datetime
import json
import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench"))
import tensor_lame  # noqa: E402  (the Lamé cylinder's mesh and field)

GLYPH_SCRIPT = """
import sys
from paraview.simple import LegacyVTKReader, TensorGlyph
reader = LegacyVTKReader(FileNames=[sys.argv[1]])
glyphs = TensorGlyph(Input=reader)
glyphs.Tensors = ['POINTS', 'stress']
glyphs.UpdatePipeline()
from paraview import servermanager
print(servermanager.Fetch(glyphs).GetNumberOfCells())
"""


def timed(args):
    start = time.perf_counter()
    out = subprocess.run([str(a) for a in args], check=True, capture_output=True, text=True).stdout
    return time.perf_counter() - start, out


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--tetrascope", default=str(ROOT / "build" / "release" / "apps" / "tetrascope"))
    p.add_argument("--dense", type=int, default=16)
    p.add_argument("--min-cl", type=float, default=0.3)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--work", default=str(ROOT / "bench" / "out" / "tensor_surfaces"))
    p.add_argument("--output", default=str(ROOT / "bench" / "results" / "tensor_surfaces.json"))
    a = p.parse_args()
    work = Path(a.work)
    work.mkdir(parents=True, exist_ok=True)
    mesh = work / "lame_504k.vtk"
    if not mesh.exists():
        tensor_lame.write_mesh(mesh, nr=40, nt=60, nz=35)
    runs = {"lines": [], "surfaces": [], "paraview_tensor_glyph": []}
    outputs = {}
    for _ in range(a.repeat):
        s, out = timed([a.tetrascope, "streamlines", mesh, "--field", "stress", "--seeds", f"dense:{a.dense}", "--min-cl", a.min_cl, "-o", work / "lines.vtk", "--json"])
        runs["lines"].append(s)
        outputs["lines"] = json.loads(out)
        s, out = timed([a.tetrascope, "diffusion-surfaces", mesh, "--tensor", "stress", "--seeds", f"dense:{a.dense}", "-o", work / "surfaces.vtk", "--json"])
        runs["surfaces"].append(s)
        outputs["surfaces"] = json.loads(out)
        if shutil.which("pvpython"):
            script = work / "glyph.py"
            script.write_text(GLYPH_SCRIPT)
            s, out = timed(["pvpython", script, mesh])
            runs["paraview_tensor_glyph"].append(s)
            outputs["paraview_tensor_glyph"] = {"cells": int(out.strip().splitlines()[-1])}
    medians = {k: statistics.median(v) for k, v in runs.items() if v}
    record = {"date": datetime.date.today().isoformat(), "load": os.getloadavg(), "repeat": a.repeat,
              "commit": subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip(),
              "mesh": {"name": mesh.name, "tets": outputs["surfaces"]["tets"]}, "dense": a.dense, "min_cl": a.min_cl,
              "seconds_median": medians, "runs": runs,
              "lines": {k: outputs["lines"][k] for k in ("lines", "points", "seeds", "stops", "load_seconds", "seconds")},
              "surfaces": {k: outputs["surfaces"][k] for k in ("surfaces", "triangles", "vertices", "seeds", "seeds_refused", "operations", "anisotropy", "load_seconds", "seconds")},
              "paraview_tensor_glyph": outputs.get("paraview_tensor_glyph"),
              "method": "whole processes, each the median of repeat runs; the mesh read from the same legacy VTK file by each"}
    if "paraview_tensor_glyph" in medians:
        record["ratio_lines_and_surfaces_to_paraview"] = (medians["lines"] + medians["surfaces"]) / medians["paraview_tensor_glyph"]
    Path(a.output).write_text(json.dumps(record, indent=1) + "\n")
    print(json.dumps({"seconds_median": medians, "ratio": record.get("ratio_lines_and_surfaces_to_paraview")}))


if __name__ == "__main__":
    main()
