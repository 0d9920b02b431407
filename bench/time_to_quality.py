#!/usr/bin/python3
"""Time to 35 dB: the frame time of the smallest cut that reaches 35 dB of the full mesh,
against the full mesh's frame time, per view.

For each view (a camera and a transfer function), the full mesh is drawn by the exact CPU
integrator at 256x192 (`render --reference`; isosurfaces by the GL renderer), and so is the
store's cut at each budget of a ladder (percent of the input's tets); the first budget whose
PSNR against the full mesh reaches the target is the cut that counts. Its frame time and the
full mesh's are taken at 1024x768 with each backend of --backends (`render --backend B --json`
median_ms of --repeat runs, one frame each, the same view): `gl`, the GL renderer (the
default), and `cpu`, the CPU ray caster (which does not draw isosurfaces without the volume:
no time there); the PSNR does not depend on the backend. Views are named (--view, with one
--tf for all) or drawn from a seed (--seed, --views: cameras inside and outside and transfer
functions placed on the attribute's histogram, as bench/fidelity_random.py draws them; a new
seed for each record). Named views without --tf take the default ramp over the attribute's
range (the mesh and its store alike since 2026-11-28; records before that need a --tf).
Writes one record (the views, every rung, both times and their ratio per backend under
"times", and for the first backend also as full_ms_1024x768, reached.ms_1024x768 and ratio, the
fields of the records before --backends) into bench/results/time_to_quality.json, keyed by mesh
and tag.

  bench/time_to_quality.py MESH STORE (--view NAME=CAMERA ... [--tf TF.json] | --seed S --views K)
                           [--target 35] [--ladder 0.5,1,2,5,10,20,40] [--backends gl,cpu] [--repeat 3] [--tag T]
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
BACKENDS = {"gl": "the GL renderer", "cpu": "the CPU ray caster"}


def run(args):
    return subprocess.run([str(a) for a in args], check=True, capture_output=True, text=True).stdout


def view_args(view, work, name):
    """render's options for the view's transfer function or isosurface (the named views' --tf)."""
    if view["kind"] == "iso":
        return ["--mode", "iso", "--attribute", view["tf"]["attribute"], "--iso", repr(view["tf"]["iso"])]
    if view["tf"] is None:
        return []
    path = work / f"{name}.tf.json"
    path.write_text(json.dumps(view["tf"]))
    return ["--tf", path]


def render(binary, source, image, view, size, extra=()):
    args = [binary, "render", source, "-o", image, "--camera", view["camera"], "--size", size, "--json", *view["args"], *extra]
    if size == "256x192" and view["kind"] != "iso":
        args.append("--reference")
    return json.loads(run(args).strip().splitlines()[-1])


def image_of(base, view):
    """The 256x192 picture PSNR is measured on: the exact integrator's float image, or GL's for isosurfaces."""
    return psnr_module.read_png(f"{base}.png") if view["kind"] == "iso" else psnr_module.read_pfm(f"{base}.reference.pfm")


def frame_ms(a, source, image, view, backend, extra=()):
    """render's median_ms at 1024x768 with one backend, the median of --repeat runs; None where it does not draw the view."""
    try:
        return statistics.median(
            render(a.tetrascope, source, image, view, "1024x768", [*extra, "--backend", backend])["median_ms"] for _ in range(a.repeat))
    except subprocess.CalledProcessError as e:
        if "does not draw" in (e.stderr or ""):
            return None
        raise


def frame_times(a, view, base, reached):
    """The full mesh's and the reached cut's frame times and their ratio, per backend."""
    times = {}
    for backend in a.backends:
        full = frame_ms(a, a.mesh, f"{base}.full_time.{backend}.png", view, backend)
        cut = frame_ms(a, a.store, f"{base}.cut_time.{backend}.png", view, backend, ["--budget", reached["budget"]]) if reached else None
        times[backend] = {"full_ms": full, "cut_ms": cut, "ratio": cut / full if cut is not None and full else None}
        print(json.dumps({"view": view["name"], "backend": backend, **times[backend]}), flush=True)
    return times


def measure(a, view, input_tets, work):
    base = work / f"{Path(a.mesh).stem}.{view['name']}"
    render(a.tetrascope, a.mesh, f"{base}.full.png", view, "256x192")
    full = image_of(f"{base}.full", view)
    shown = float((abs(full / (255.0 if view["kind"] == "iso" else 1.0) - [0.1, 0.1, 0.12]).max(axis=-1) > 1.5 / 255).mean())
    rungs, reached = [], None
    for pct in [float(x) for x in a.ladder.split(",")]:
        budget = max(1, int(input_tets * pct / 100))
        cut = render(a.tetrascope, a.store, f"{base}.cut{pct:g}.png", view, "256x192", ["--budget", budget])
        db = psnr_module.psnr(full, image_of(f"{base}.cut{pct:g}", view), 255.0 if view["kind"] == "iso" else 1.0)
        rung = {"budget_pct": pct, "budget": budget, "tets": cut["cut"]["tets"], "by": cut["cut"].get("by"), "psnr_db": db}
        rungs.append(rung)
        print(json.dumps({"view": view["name"], **rung}), flush=True)
        if db >= a.target:
            reached = rung
            break
    times = frame_times(a, view, base, reached)
    first = times[a.backends[0]]
    if reached:
        reached["ms_1024x768"] = first["cut_ms"]
    out = {"view": view["name"], "camera": view["camera"], "inside": view.get("inside"), "kind": view["kind"], "tf": view["tf"], "coverage": shown,
           "full_ms_1024x768": first["full_ms"], "rungs": rungs, "reached": reached, "ratio": first["ratio"], "times": times}
    print(json.dumps(out), flush=True)
    return out


def drawn_views(a, work):
    """--views views drawn from --seed as bench/fidelity_random.py draws them."""
    import random
    import fidelity_random
    store_info = json.loads(run([a.tetrascope, "info", "--json", a.store]))
    histograms = fidelity_random.attribute_histograms(a.tetrascope, a.store, work / Path(a.mesh).stem)
    scalars = [x for x in store_info.get("attributes", []) if x.get("components", 1) == 1]
    rng = random.Random(a.seed)
    views = []
    for v in range(a.views):
        attribute = scalars[rng.randrange(len(scalars))]
        tf_attribute = {"name": attribute["name"], "min": attribute["min"], "max": attribute["max"], "histogram": histograms.get(attribute["name"])}
        view = fidelity_random.draw_view(rng, store_info["bounds"], tf_attribute, v)
        views.append(dict(view, name=f"s{a.seed}.v{v}"))
    return views


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("mesh")
    p.add_argument("store")
    p.add_argument("--view", action="append", default=[], help="NAME=CAMERA (render's --camera text)")
    p.add_argument("--tf", default="", help="the named views' transfer function (default: the opacity ramp over the attribute's range)")
    p.add_argument("--seed", type=int, help="draw --views views from this seed instead of --view")
    p.add_argument("--views", type=int, default=6)
    p.add_argument("--target", type=float, default=35.0)
    p.add_argument("--ladder", default="0.5,1,2,5,10,20,40")
    p.add_argument("--backends", default="gl", help="the backends to time, in order: gl, cpu (the first fills the old fields)")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--tag", default="")
    p.add_argument("--work", default=str(ROOT / "bench" / "out" / "time_to_quality"))
    p.add_argument("--tetrascope", default=str(ROOT / "build" / "release" / "apps" / "tetrascope"))
    p.add_argument("--commit", help="the commit --tetrascope was built from (default: HEAD when the run starts)")
    p.add_argument("--output", default=str(RESULTS))
    a = p.parse_args()
    a.commit = a.commit or run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"]).strip()
    if (a.seed is None) == (not a.view):
        p.error("give either --view or --seed")
    a.backends = [b for b in a.backends.split(",") if b]
    if not a.backends or any(b not in BACKENDS for b in a.backends):
        p.error("--backends: a list of gl and cpu")
    work = Path(a.work)
    work.mkdir(parents=True, exist_ok=True)
    input_tets = json.loads(run([a.tetrascope, "info", "--json", a.mesh]))["tetrahedra"]
    if a.seed is not None:
        views = drawn_views(a, work)
    else:
        tf = json.loads(Path(a.tf).read_text()) if a.tf else None
        views = [{"name": n, "camera": c, "kind": "tf", "tf": tf} for n, c in (spec.split("=", 1) for spec in a.view)]
    for view in views:
        view["args"] = view_args(view, work, f"{Path(a.mesh).stem}.{view['name']}")
    load_start = os.getloadavg()
    measured = [measure(a, view, input_tets, work) for view in views]
    record = {"mesh": Path(a.mesh).name, "input_tets": input_tets, "store": a.store, "tag": a.tag, "seed": a.seed, "target_db": a.target, "repeat": a.repeat,
              "backends": a.backends, "date": datetime.date.today().isoformat(), "load_start": load_start, "load": os.getloadavg(),
              "commit": a.commit,
              "method": "PSNR by the exact CPU integrator at 256x192 against the full mesh (isosurfaces: GL, 8 bits); times: "
                        + " and ".join(f"{BACKENDS[b]} (--backend {b})" for b in a.backends) + ", 1024x768, median of repeat runs of one frame",
              "views": measured}
    out = Path(a.output)
    old = json.loads(out.read_text()) if out.exists() else {"records": []}
    old["records"] = [r for r in old["records"] if not (r["mesh"] == record["mesh"] and r["tag"] == record["tag"])] + [record]
    out.write_text(json.dumps(old, indent=1))


if __name__ == "__main__":
    main()
