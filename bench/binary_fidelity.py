"""The binary segment hierarchy against the multi-triangulation on the fidelity cases: the rows of
bench/results/fidelity.json under tags `binary` (preprocess --model binary --vertices off) and
`mt-segments` (--model mt --vertices off: both cut through their segments), each next to the
uniform decimation of the same tets. Per cell (case, budget): the PSNR of each (8-bit, or the
integrator's unrounded colours with --float), binary minus MT, and each against its decimation.
Counts the cells each model wins; writes the table to bench/results/binary_hierarchy.json
("fidelity").
With --tag T, the binary rows of tag T instead (e.g. binary-r0: --dependency-ratio 0).
usage: python3 bench/binary_fidelity.py [--float] [--tag T]"""
import datetime
import json
import os
import sys

os.chdir(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
use_float = "--float" in sys.argv
btag = sys.argv[sys.argv.index("--tag") + 1] if "--tag" in sys.argv else "binary"
key, dkey = ("cut_db_float", "decimated_db_float") if use_float else ("cut_db", "decimated_db")
rows = json.load(open("bench/results/fidelity.json"))["runs"]
by = {}
for r in rows:
    if r["tag"] in (btag, "mt-segments"):
        by[(r["case"], r["budget"], r["tag"])] = r
cells = sorted({(c, b) for (c, b, _) in by}, key=lambda cb: (cb[0], ["coarsest", "5", "10", "25", "50"].index(cb[1]) if cb[1] in ["coarsest", "5", "10", "25", "50"] else 9))
table = []
wins = {"binary": 0, "mt": 0, "tie": 0}
beats_decimation = {"binary": [0, 0], "mt": [0, 0]}
print(f"{'case':24} {'budget':>8} {'bin tets':>9} {'bin dB':>7} {'dec dB':>7} {'mt tets':>9} {'mt dB':>7} {'dec dB':>7} {'bin-mt':>7}")
for case, budget in cells:
    b, m = by.get((case, budget, btag)), by.get((case, budget, "mt-segments"))
    if not b or not m or b.get(key) is None or m.get(key) is None:
        continue
    diff = round(b[key] - m[key], 2)
    wins["binary" if diff > 0.1 else "mt" if diff < -0.1 else "tie"] += 1
    if budget != "coarsest":
        for name, r in (("binary", b), ("mt", m)):
            beats_decimation[name][0] += r[key] >= r[dkey]
            beats_decimation[name][1] += 1
    table.append({"case": case, "budget": budget, "binary_tets": b["cut_tets"], "binary_db": b[key], "binary_decimated_db": b[dkey],
                  "mt_tets": m["cut_tets"], "mt_db": m[key], "mt_decimated_db": m[dkey], "binary_minus_mt_db": diff})
    print(f"{case:24} {budget:>8} {b['cut_tets']:>9} {b[key]:>7} {b[dkey]:>7} {m['cut_tets']:>9} {m[key]:>7} {m[dkey]:>7} {diff:>7}")
print(f"cells: binary higher (> 0.1 dB) {wins['binary']}, MT higher {wins['mt']}, within 0.1 dB {wins['tie']}")
for name, (won, of) in beats_decimation.items():
    print(f"{name}: at or above the decimation of its own tets in {won} of {of} cells at 5-50%")
path = "bench/results/binary_hierarchy.json"
old = json.load(open(path)) if os.path.exists(path) else {}
old["fidelity" + ("" if btag == "binary" else "_" + btag) + ("_float" if use_float else "")] = {"binary_tag": btag, "cells": table, "wins": wins, "at_or_above_decimation_5_50": beats_decimation,
                                                    "method": "bench/fidelity_bench.sh rows of tags binary and mt-segments (the same binary, one run each), PSNR against the full mesh by the exact CPU integrator (isosurfaces: GL); " + ("unrounded colours" if use_float else "8-bit images")}
old["date"] = datetime.date.today().isoformat()
json.dump(old, open(path, "w"), indent=1)
