#!/usr/bin/python3
"""Time to 35 dB: the frame time of the smallest cut that reaches 35 dB of the full mesh,
against the full mesh's frame time, per view.

For each view (a camera and a transfer function), the full mesh is drawn by the exact CPU
integrator at 256x192 (`render --reference`), and so is the store's cut at each budget of a
ladder (percent of the input's tets); the first budget whose float PSNR against the full mesh
reaches the target is the cut that counts. Its frame time and the full mesh's are the GL
renderer's at 1024x768 (`render --json` median_ms of --repeat runs, one frame each, the same
view). Writes one record (the views, every rung, both times and their ratio) into
bench/results/time_to_quality.json, keyed by mesh and tag.

  bench/time_to_quality.py MESH STORE --view NAME=CAMERA ... [--tf TF.json] [--target 35]
                           [--ladder 0.5,1,2,5,10,20,40] [--repeat 3] [--tag T]
"""
import argparse
import datetime
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench"))
import psnr as psnr_module  # noqa: E402

RESULTS = ROOT / "bench" / "results" / "time_to_quality.json"


def run(args):
    return subprocess.run([str(a) for a in args], check=True, capture_output=True, text=True).stdout


def render(binary, source, out, camera, tf, size, extra=()):
    args = [binary, "render", source, "-o", out, "--camera", camera, "--size", size, "--json", *extra]
    if tf:
        args += ["--tf", tf]
    return json.loads(run(args).strip().splitlines()[-1])


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("mesh")
    p.add_argument("store")
    p.add_argument("--view", action="append", required=True, help="NAME=CAMERA (render's --camera text)")
    p.add_argument("--tf", default="")
    p.add_argument("--target", type=float, default=35.0)
    p.add_argument("--ladder", default="0.5,1,2,5,10,20,40")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--tag", default="")
    p.add_argument("--work", default=str(ROOT / "bench" / "out" / "time_to_quality"))
    p.add_argument("--tetrascope", default=str(ROOT / "build" / "release" / "apps" / "tetrascope"))
    p.add_argument("--output", default=str(RESULTS))
    a = p.parse_args()
    work = Path(a.work)
    work.mkdir(parents=True, exist_ok=True)
    input_tets = json.loads(run([a.tetrascope, "info", "--json", a.mesh]))["tetrahedra"]
    views = []
    for spec in a.view:
        name, camera = spec.split("=", 1)
        base = work / f"{Path(a.mesh).stem}.{name}"
        render(a.tetrascope, a.mesh, f"{base}.full.png", camera, a.tf, "256x192", ["--reference"])
        full = psnr_module.read_pfm(f"{base}.full.reference.pfm")
        full_ms = statistics.median(render(a.tetrascope, a.mesh, f"{base}.full_time.png", camera, a.tf, "1024x768")["median_ms"] for _ in range(a.repeat))
        rungs, reached = [], None
        for pct in [float(x) for x in a.ladder.split(",")]:
            budget = max(1, int(input_tets * pct / 100))
            cut = render(a.tetrascope, a.store, f"{base}.cut{pct:g}.png", camera, a.tf, "256x192", ["--reference", "--budget", budget])
            db = psnr_module.psnr(full, psnr_module.read_pfm(f"{base}.cut{pct:g}.reference.pfm"), 1.0)
            rung = {"budget_pct": pct, "budget": budget, "tets": cut["cut"]["tets"], "by": cut["cut"].get("by"), "psnr_db": db}
            rungs.append(rung)
            print(json.dumps({"view": name, **rung}), flush=True)
            if db >= a.target:
                rung["ms_1024x768"] = statistics.median(
                    render(a.tetrascope, a.store, f"{base}.cut_time.png", camera, a.tf, "1024x768", ["--budget", budget])["median_ms"] for _ in range(a.repeat))
                reached = rung
                break
        views.append({"view": name, "camera": camera, "full_ms_1024x768": full_ms, "rungs": rungs,
                      "reached": reached, "ratio": reached["ms_1024x768"] / full_ms if reached else None})
        print(json.dumps(views[-1]), flush=True)
    record = {"mesh": Path(a.mesh).name, "input_tets": input_tets, "store": a.store, "tag": a.tag, "target_db": a.target, "repeat": a.repeat,
              "date": datetime.date.today().isoformat(), "load": os.getloadavg(),
              "commit": run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"]).strip(),
              "method": "PSNR by the exact CPU integrator at 256x192 against the full mesh; times: GL renderer, 1024x768, median of repeat runs of one frame",
              "views": views}
    out = Path(a.output)
    old = json.loads(out.read_text()) if out.exists() else {"records": []}
    old["records"] = [r for r in old["records"] if not (r["mesh"] == record["mesh"] and r["tag"] == record["tag"])] + [record]
    out.write_text(json.dumps(old, indent=1))


if __name__ == "__main__":
    main()
