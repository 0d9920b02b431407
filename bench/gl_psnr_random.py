#!/usr/bin/python3
"""The GL renderer's full-mesh volume image against the exact CPU integrator on views drawn
from a seed (cameras inside and outside, transfer functions placed on the attribute's
histogram, as bench/fidelity_random.py draws them; isosurface views are skipped), for one or
more tetrascope binaries in the same run: `render --reference` at 256x192 gives each PSNR.
Writes a record keyed by seed into bench/results/gl_psnr_random.json.

  bench/gl_psnr_random.py --seed S [--views K] [--meshes A.vtk,B.vtk] --work DIR
                          --binary LABEL=PATH [--binary LABEL=PATH ...]
(a store per mesh is needed only for the histograms; DIR/<mesh>.store is used, or built)
"""
import argparse
import datetime
import json
import os
import random
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench"))
import fidelity_random  # noqa: E402

RESULTS = ROOT / "bench" / "results" / "gl_psnr_random.json"


def run(args):
    return subprocess.run([str(a) for a in args], check=True, capture_output=True, text=True).stdout


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seed", type=int, required=True)
    p.add_argument("--views", type=int, default=4)
    p.add_argument("--meshes", default=",".join(str(fidelity_random.DATA / m) for m in fidelity_random.DEFAULT_MESHES))
    p.add_argument("--work", required=True)
    p.add_argument("--binary", action="append", required=True, help="LABEL=PATH")
    p.add_argument("--output", default=str(RESULTS))
    a = p.parse_args()
    binaries = dict(spec.split("=", 1) for spec in a.binary)
    first = next(iter(binaries.values()))
    work = Path(a.work)
    work.mkdir(parents=True, exist_ok=True)
    rows = []
    for mesh in a.meshes.split(","):
        stem = Path(mesh).stem
        store = work / f"{stem}.store"
        if not store.exists():
            run([first, "preprocess", mesh, "-o", store])
        info = json.loads(run([first, "info", "--json", store]))
        histograms = fidelity_random.attribute_histograms(first, store, work / stem)
        scalars = [x for x in info.get("attributes", []) if x.get("components", 1) == 1]
        rng = random.Random(f"{a.seed}:{stem}")
        for v in range(a.views):
            attribute = scalars[rng.randrange(len(scalars))]
            tf_attribute = {"name": attribute["name"], "min": attribute["min"], "max": attribute["max"], "histogram": histograms.get(attribute["name"])}
            view = fidelity_random.draw_view(rng, info["bounds"], tf_attribute, v)
            if view["kind"] == "iso":
                continue
            tf = work / f"{stem}.gl{a.seed}.v{v}.tf.json"
            tf.write_text(json.dumps(view["tf"]))
            row = {"mesh": Path(mesh).name, "view": v, "inside": view["inside"], "kind": view["kind"], "camera": view["camera"], "tf": view["tf"]}
            for label, binary in binaries.items():
                out = json.loads(run([binary, "render", mesh, "-o", work / f"{stem}.gl.{label}.png", "--camera", view["camera"], "--size", "256x192", "--tf", tf,
                                      "--backend", "gl", "--reference", "--json"]).strip().splitlines()[-1])
                row[f"{label}_db"] = out["reference_psnr_db"]
            print(json.dumps({k: row[k] for k in row if k not in ("camera", "tf")}), flush=True)
            rows.append(row)
    summary = {label: {"median_db": statistics.median(r[f"{label}_db"] for r in rows), "min_db": min(r[f"{label}_db"] for r in rows)} for label in binaries} if rows else {}
    record = {"seed": a.seed, "date": datetime.date.today().isoformat(), "load": os.getloadavg(), "binaries": binaries, "size": "256x192",
              "method": "render --reference: the GL image of the whole mesh against the exact CPU integrator's, float PSNR", "views": rows, "summary": summary}
    out = Path(a.output)
    old = json.loads(out.read_text()) if out.exists() else {"records": []}
    old["records"] = [r for r in old["records"] if r["seed"] != a.seed] + [record]
    out.write_text(json.dumps(old, indent=1) + "\n")
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
