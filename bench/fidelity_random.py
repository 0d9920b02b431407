#!/usr/bin/python3
"""The best picture per tet on views nobody tuned for: the store's cut against the whole mesh
decimated uniformly to the same budget, on views drawn at random from a seed.

For each mesh, VIEWS views are drawn from the seed: eyes outside (a random direction, 1.2 to 3
bounding-box diagonals from a point near the centre) and inside (a random point of the box,
looking at another), each with a transfer function of one of three kinds placed on the
attribute's own value histogram (a narrow band around a value drawn from the histogram, a
broad ramp from a drawn value up, or an isosurface at a drawn value). Every view is drawn by
the exact CPU integrator (`render --reference`, float PSNR; isosurfaces by the GL renderer, as
8-bit images) for the full mesh, the cut at each budget (percent of the input's tets) and the
whole mesh decimated by `tetrascope simplify --tets` to that budget. A cell is one view at one
budget: the cut's PSNR minus the decimation's, and the share of its budget the cut used.

Writes bench/results/fidelity_random.json: one record per seed (a new seed for each record),
with every cell and the distribution per budget (median, quartiles, the share of cells that
lose by more than 0.5 dB) and per mesh.

  bench/fidelity_random.py --seed S [--views 20] [--budgets 1,5,10,25,50] [--size 256x192]
                           [--meshes a.vtk,b.vtk] [--tetrascope BIN] [--output FILE]
"""
import argparse
import datetime
import json
import math
import os
import random
import statistics
import struct
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "bench" / "out" / "fidelity_random"
RESULTS = ROOT / "bench" / "results" / "fidelity_random.json"
DATA = ROOT.parent / "shared" / "data"
DEFAULT_MESHES = ["onera_m6_potential.vtk", "nasa_oxygen_post.vtk", "fea_bracket.vtk", "nasa_bluntfin.vtk"]

sys.path.insert(0, str(ROOT / "bench"))
import psnr as psnr_module  # noqa: E402  (bench/psnr.py: PNG and PFM PSNR)


def run(args, **kw):
    return subprocess.run([str(a) for a in args], check=True, capture_output=True, text=True, **kw).stdout


TIMEOUT = None  # seconds a render may take (--timeout); a view one of whose renders passes it is skipped


def info(binary, path):
    return json.loads(run([binary, "info", "--json", path]))


def attribute_histograms(binary, store, base, bins=64):
    """64-bin histograms of every scalar attribute over the store's coarsest cut (its vertices
    are a sample of the mesh's), from `tetrascope cut` written as binary legacy VTK."""
    path = Path(f"{base}.coarse.vtk")
    if not path.exists():
        run([binary, "cut", store, "--budget", 1, "-o", path])
    data = path.read_bytes()
    at = data.find(b"POINT_DATA ")
    count = int(data[at + 11:data.find(b"\n", at)])
    out = {}
    while True:
        at = data.find(b"SCALARS ", at)
        if at < 0:
            return out
        line_end = data.find(b"\n", at)
        name, kind, components = data[at + 8:line_end].decode().split()[:3]
        start = data.find(b"\n", line_end + 1) + 1  # after LOOKUP_TABLE default
        if kind != "float" or components != "1":
            at = start
            continue
        values = [v for v in struct.unpack(f">{count}f", data[start:start + 4 * count]) if math.isfinite(v)]
        at = start + 4 * count
        if values:
            lo, hi = min(values), max(values)
            counts = [0] * bins
            for v in values:
                counts[min(bins - 1, int((v - lo) / (hi - lo) * bins)) if hi > lo else 0] += 1
            out[name] = (lo, hi, counts)


def histogram_value(rng, attribute):
    """A value drawn from the attribute's histogram (so bands sit where the data is)."""
    lo, hi, counts = attribute.get("histogram") or (attribute["min"], attribute["max"], [])
    if not counts or sum(counts) == 0 or not hi > lo:
        return lo + rng.random() * (hi - lo)
    bin_ = rng.choices(range(len(counts)), weights=counts)[0]
    return lo + (bin_ + rng.random()) / len(counts) * (hi - lo)


def draw_view(rng, bounds, attribute, index):
    lo, hi = bounds["min"], bounds["max"]
    centre = [(a + b) / 2 for a, b in zip(lo, hi)]
    diagonal = math.dist(lo, hi) or 1.0
    inside = index % 2 == 1  # outside and inside alternate
    point = lambda: [a + rng.random() * (b - a) for a, b in zip(lo, hi)]  # noqa: E731
    if inside:
        eye, target = point(), point()
        if math.dist(eye, target) < 0.05 * diagonal:
            target = centre
        fov = rng.uniform(50, 80)
    else:
        target = [c + rng.uniform(-0.2, 0.2) * (b - a) for c, a, b in zip(centre, lo, hi)]
        z = rng.uniform(-1, 1)
        phi = rng.uniform(0, 2 * math.pi)
        direction = [math.sqrt(1 - z * z) * math.cos(phi), math.sqrt(1 - z * z) * math.sin(phi), z]
        distance = rng.uniform(1.2, 3.0) * diagonal
        eye = [t + distance * d for t, d in zip(target, direction)]
        fov = rng.uniform(25, 45)
    forward = [t - e for t, e in zip(target, eye)]
    up = [0, 0, 1] if abs(forward[2]) < 0.9 * math.hypot(*forward) else [0, 1, 0]
    camera = "eye={},{},{},target={},{},{},up={},{},{},fov={:.1f}".format(*eye, *target, *up, fov)
    kind = ["narrow", "broad", "iso"][rng.randrange(3)]
    lo_v, hi_v = attribute["min"], attribute["max"]
    span = (hi_v - lo_v) or 1.0
    value = min(max(histogram_value(rng, attribute), lo_v + 1e-6 * span), hi_v - 1e-6 * span)  # the histogram (of the coarsest level) may be wider
    if kind == "narrow":
        width = span * rng.uniform(0.02, 0.06)
        opacity = [[lo_v, 0], [value - width, 0], [value, rng.uniform(0.5, 0.9)], [value + width, 0], [hi_v, 0]]
        opacity = sorted(opacity, key=lambda p: p[0])
        tf = {"attribute": attribute["name"], "range": [lo_v, hi_v], "colormap": "viridis", "opacity": opacity}
    elif kind == "broad":
        tf = {"attribute": attribute["name"], "range": [lo_v, hi_v], "colormap": "viridis", "opacity": [[lo_v, 0], [value, 0], [hi_v, rng.uniform(0.3, 0.8)]]}
    else:
        tf = {"attribute": attribute["name"], "iso": value}
    return {"camera": camera, "inside": inside, "kind": kind, "tf": tf}


def render(binary, source, image, view, size, budget=None, extra=()):
    args = [binary, "render", source, "-o", f"{image}.png", "--camera", view["camera"], "--size", size, "--json", *extra]
    if view["kind"] == "iso":
        args += ["--mode", "iso", "--attribute", view["tf"]["attribute"], "--iso", repr(view["tf"]["iso"])]
    else:
        tf_file = Path(f"{image}.tf.json")
        tf_file.write_text(json.dumps(view["tf"]))
        args += ["--tf", tf_file, "--reference"]
    if budget is not None:
        args += ["--budget", budget]
    return json.loads(run(args, timeout=TIMEOUT).strip().splitlines()[-1])


def compared(full, other, view):
    if view["kind"] == "iso":
        return psnr_module.psnr(psnr_module.read_png(f"{full}.png"), psnr_module.read_png(f"{other}.png"))
    return psnr_module.psnr(psnr_module.read_pfm(f"{full}.reference.pfm"), psnr_module.read_pfm(f"{other}.reference.pfm"), 1.0)


def coverage(full, view):
    """The share of the full mesh's image the view shows something in: pixels that differ from
    the background (RenderSettings::background, 0.1 0.1 0.12) by more than one 8-bit level."""
    image = psnr_module.read_png(f"{full}.png") / 255.0 if view["kind"] == "iso" else psnr_module.read_pfm(f"{full}.reference.pfm")
    background = [0.1, 0.1, 0.12]
    return float((abs(image - background).max(axis=-1) > 1.5 / 255).mean())


def quartiles(values):
    if not values:
        return None
    values = sorted(values)
    q = statistics.quantiles(values, n=4, method="inclusive") if len(values) > 1 else [values[0]] * 3
    return {"median": statistics.median(values), "q1": q[0], "q3": q[2], "min": values[0], "max": values[-1]}


MIN_COVERAGE = 0.05  # views showing less of the image are reported apart (their PSNR says little)


def summary(cells):
    out = {}
    for key in sorted({c["budget_pct"] for c in cells}):
        at = [c for c in cells if c["budget_pct"] == key and c["gain_db"] is not None and c.get("coverage", 1) >= MIN_COVERAGE]
        gains = [c["gain_db"] for c in at]
        out[str(key)] = {
            "cells": len(at),
            "cells_showing_little": sum(1 for c in cells if c["budget_pct"] == key and c.get("coverage", 1) < MIN_COVERAGE),
            "gain_db": quartiles(gains),
            "losing_over_0_5_db": sum(g < -0.5 for g in gains) / len(gains) if gains else None,
            "beating_by_3_db": sum(g >= 3 for g in gains) / len(gains) if gains else None,
            "budget_used": quartiles([c["budget_used"] for c in at]),
        }
        # the vertex front's tets split only for other splits, and of them those out of view
        forced = [c for c in at if c.get("forced_tets") is not None and c["cut_tets"]]
        if forced:
            out[str(key)]["forced_share"] = quartiles([c["forced_tets"] / c["cut_tets"] for c in forced])
            out[str(key)]["unseen_share"] = quartiles([c["unseen_tets"] / c["cut_tets"] for c in forced])
    return out


def finish(record, cells):
    record["summary"] = summary(cells)
    record["by_mesh"] = {m: summary([c for c in cells if c["mesh"] == m]) for m in sorted({c["mesh"] for c in cells})}
    record["by_eye"] = {side: summary([c for c in cells if c["inside"] == (side == "inside")]) for side in ("inside", "outside")}
    record["by_kind"] = {k: summary([c for c in cells if c["kind"] == k]) for k in sorted({c["kind"] for c in cells})}
    record["min_coverage"] = MIN_COVERAGE


def resummarise(a):
    results = Path(a.output)
    old = json.loads(results.read_text())
    for record in old["records"]:
        if record["seed"] != a.seed:
            continue
        for c in record["cells"]:
            if "coverage" not in c:
                name = Path(a.work) / f"{Path(c['mesh']).stem}.s{a.seed}.v{c['view']}"
                c["coverage"] = coverage(f"{name}.full", c)
        finish(record, record["cells"])
        print(json.dumps(record["summary"], indent=1))
    results.write_text(json.dumps(old, indent=1))


def measure_view(binary, mesh, store, name, view, v, a, budgets, decimated):
    """The full mesh's image of one view and a cell a budget: the cut against the decimation."""
    render(binary, mesh, f"{name}.full", view, a.size)
    shown = coverage(f"{name}.full", view)
    cells = []
    for pct in budgets:
        tets, path = decimated[pct]
        cut = render(binary, store, f"{name}.cut{pct:g}", view, a.size, budget=tets, extra=a.render_args.split())
        render(binary, path, f"{name}.dec{pct:g}", view, a.size)
        cut_db = compared(f"{name}.full", f"{name}.cut{pct:g}", view)
        dec_db = compared(f"{name}.full", f"{name}.dec{pct:g}", view)
        gain = None if not (math.isfinite(cut_db) and math.isfinite(dec_db)) else cut_db - dec_db
        cell = {"mesh": mesh.name, "view": v, "inside": view["inside"], "kind": view["kind"], "camera": view["camera"], "tf": view["tf"],
                "coverage": shown, "budget_pct": pct, "budget_tets": tets, "cut_tets": cut["tets"], "budget_used": cut["tets"] / tets,
                "cut_by": cut.get("cut", {}).get("by"), "over_budget": cut.get("cut", {}).get("over_budget"),
                "forced_tets": cut.get("cut", {}).get("forced_tets"), "unseen_tets": cut.get("cut", {}).get("unseen_tets"),
                "run_time_valid": cut.get("cut", {}).get("run_time_valid"), "refused_splits": cut.get("cut", {}).get("refused_splits"),
                "cut_db": cut_db if math.isfinite(cut_db) else None, "decimated_db": dec_db if math.isfinite(dec_db) else None,
                "gain_db": gain, "cut_estimated_error": cut.get("cut_estimated_error")}
        cells.append(cell)
        print(json.dumps({k: cell[k] for k in ("mesh", "view", "kind", "inside", "budget_pct", "cut_tets", "cut_db", "decimated_db", "gain_db")}), flush=True)
    return cells


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, required=True, help="draws the views; use a new one for each record")
    parser.add_argument("--views", type=int, default=20)
    parser.add_argument("--budgets", default="1,5,10,25,50")
    parser.add_argument("--size", default="256x192")
    parser.add_argument("--meshes", default=",".join(str(DATA / m) for m in DEFAULT_MESHES))
    parser.add_argument("--tetrascope", default=str(ROOT / "build" / "release" / "apps" / "tetrascope"))
    parser.add_argument("--commit", help="the commit --tetrascope was built from (default: HEAD when the run starts)")
    parser.add_argument("--preprocess-args", default="", help="extra options for tetrascope preprocess")
    parser.add_argument("--output", default=str(RESULTS), help="the results file (records by seed)")
    parser.add_argument("--work", default=str(OUT), help="where stores, decimations and images are kept (a store there is reused)")
    parser.add_argument("--render-args", default="", help="extra options for tetrascope render of the cut (e.g. --lod segments)")
    parser.add_argument("--timeout", type=float, default=0, help="skip a view (counted in the record) when one of its renders takes longer (s; 0: no limit)")
    parser.add_argument("--summarise", action="store_true", help="only recompute the record of --seed from its cells and images")
    a = parser.parse_args()
    a.commit = a.commit or run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"]).strip()
    if a.summarise:
        return resummarise(a)
    global TIMEOUT
    TIMEOUT = a.timeout or None
    binary = a.tetrascope
    skipped = []
    budgets = [float(b) for b in a.budgets.split(",")]
    out = Path(a.work)
    out.mkdir(parents=True, exist_ok=True)
    rng = random.Random(a.seed)
    cells = []
    for mesh in [Path(m) for m in a.meshes.split(",") if m]:
        if not mesh.is_file():
            print(f"skip {mesh}: not present", file=sys.stderr)
            continue
        base = out / mesh.stem
        store = Path(f"{base}.store")
        if not (store / "manifest.json").exists():
            run([binary, "preprocess", mesh, "-o", store, "--progress", "none", "--force"] + a.preprocess_args.split())
        mesh_info = info(binary, mesh)
        store_info = info(binary, store)
        input_tets = mesh_info["tetrahedra"]
        histograms = attribute_histograms(binary, store, base)
        scalars = [dict(x, histogram=histograms.get(x["name"])) for x in store_info.get("attributes", []) if x.get("components", 1) == 1]
        decimated = {}
        for pct in budgets:  # the uniform decimation at each budget, once per mesh
            tets = max(1, int(input_tets * pct / 100))
            path = Path(f"{base}.dec{tets}.vtk")
            if not path.exists():
                run([binary, "simplify", mesh, "-o", path, "--method", "qem", "--tets", tets])
            decimated[pct] = (tets, path)
        for v in range(a.views):
            attribute = scalars[rng.randrange(len(scalars))]
            tf_attribute = {"name": attribute["name"], "min": attribute["min"], "max": attribute["max"], "histogram": attribute.get("histogram")}
            view = draw_view(rng, store_info["bounds"], tf_attribute, v)
            name = out / f"{mesh.stem}.s{a.seed}.v{v}"
            try:
                view_cells = measure_view(binary, mesh, store, name, view, v, a, budgets, decimated)
            except subprocess.TimeoutExpired:
                skipped.append({"mesh": mesh.name, "view": v, "camera": view["camera"], "kind": view["kind"], "reason": f"a render took over {a.timeout:g} s"})
                print(json.dumps(skipped[-1]), flush=True)
                continue
            cells += view_cells
    record = {"seed": a.seed, "skipped_views": skipped, "date": datetime.date.today().isoformat(), "views_per_mesh": a.views, "budgets_pct": budgets, "size": a.size,
              "commit": a.commit, "preprocess_args": a.preprocess_args, "render_args": a.render_args,
              "method": "PSNR against the full mesh by the exact CPU integrator (float colours; isosurfaces: GL, 8 bits); the decimation by tetrascope simplify --tets to the budget; gain = cut - decimation",
              "cells": cells}
    finish(record, cells)
    results = Path(a.output)
    old = json.loads(results.read_text()) if results.exists() else {"records": []}
    old["records"] = [r for r in old.get("records", []) if r.get("seed") != a.seed] + [record]
    results.write_text(json.dumps(old, indent=1))
    print(json.dumps(record["summary"], indent=1))


if __name__ == "__main__":
    main()
