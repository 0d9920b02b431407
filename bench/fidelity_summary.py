"""The fidelity goals over the rows of bench/results/fidelity.json: per case, the cut's PSNR minus
the decimation's at the same tets (dB; > 0: the cut wins) at the coarsest level and 5/10/25/50%,
then over the volume cells at 5-50%: how many lose, by more than 1 dB, the median and the worst;
how many 10-25% cells are >= 3 dB better; how many coarsest levels are within 1 dB. With
--float, by the PSNR of the integrator's unrounded colours (cut_db_float, rows from tag float32 on);
with --gl, by the GL renderer's images against the GL image of the full mesh (cut_db_gl,
rows from tag float32's re-run on). With --at-budget, against the decimation to the budget asked for rather than to the
cut's tets, where the cut stops short of its budget (decimated_at_budget, rows from tag float32's re-run on;
older rows are left out).
usage: python3 bench/fidelity_summary.py [--float|--gl] [--at-budget] [--median] TAG [TAG...] [--for CASE=TAG ...]
A case takes the first TAG it has rows of, unless --for names its tag (the defaults differ by
mesh: e.g. the uniform meshes' rows under one tag, the graded ones' under another). With
--median every cell is the median over the TAGs that have it (the same build from several
--seed values: one partition's luck moves a cell by a median 2.6 dB, tags float32/seed2/seed3)."""
import json
import os
import statistics
import sys

from fidelity_rows import choose_tags, volume_cases

os.chdir(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
args = sys.argv[1:]
use_float = "--float" in args
use_gl = "--gl" in args
use_median = "--median" in args
at_budget = "--at-budget" in args
if use_float and use_gl:
    raise SystemExit("--float and --gl: one PSNR at a time")
args = [a for a in args if a not in ("--float", "--gl", "--median", "--at-budget")]
given = {}
while "--for" in args:
    i = args.index("--for")
    case, tag = args[i + 1].split("=", 1)
    given[case] = tag
    del args[i:i + 2]
if not args:
    raise SystemExit(__doc__)
tags = args
cut_key, dec_key = ("cut_db_float", "decimated_db_float") if use_float else ("cut_db_gl", "decimated_db_gl") if use_gl else ("cut_db", "decimated_db")
rows = [r for r in json.load(open("bench/results/fidelity.json"))["runs"] if r["tag"] in tags or r["tag"] in given.values()]
if at_budget:  # the decimation to the whole budget where the cut stopped short of it
    rows = [dict(r) for r in rows if "budget_tets" in r]
    field = {"cut_db": "db", "cut_db_float": "db_float", "cut_db_gl": "db_gl"}[cut_key]
    for r in rows:
        if r.get("decimated_at_budget"):
            r[dec_key] = r["decimated_at_budget"][field]
cases = []
for r in rows:
    if r["case"] not in cases:
        cases.append(r["case"])
chosen = choose_tags(rows, tags, given)
volume_case = volume_cases()
budgets = ["coarsest", "5", "10", "25", "50"]
if use_median:  # a cell: the median gain over the tags
    gains = {}
    for r in rows:
        if r["tag"] in tags and r.get(cut_key) is not None:
            gains.setdefault((r["case"], r["budget"]), []).append(r[cut_key] - r[dec_key])
    cell = {k: {"gain": statistics.median(v), "budget": k[1], "runs": len(v)} for k, v in gains.items()}
    chosen = {c: f"median of {max((v['runs'] for k, v in cell.items() if k[0] == c), default=0)}" for c in cases}
else:
    cell = {(r["case"], r["budget"]): r for r in rows if r["tag"] == chosen.get(r["case"]) and r.get(cut_key) is not None}


def gain(r):
    return r["gain"] if "gain" in r else r[cut_key] - r[dec_key]


print(f"{'case':22} {'tag':12} " + " ".join(f"{b:>8}" for b in budgets))
for c in cases:
    if not any((c, b) in cell for b in budgets):
        continue
    print(f"{c:22} {chosen[c]:12} " + " ".join(f"{gain(cell[(c, b)]):+8.1f}" if (c, b) in cell else f"{'.':>8}" for b in budgets))
volume = [r for (c, b), r in cell.items() if b in budgets[1:] and c in volume_case]
if volume:
    d = [gain(r) for r in volume]
    middle = [gain(r) for r in volume if r["budget"] in ("10", "25")]
    coarsest = [gain(r) for (c, b), r in cell.items() if b == "coarsest" and c in volume_case]
    print(json.dumps({"psnr": cut_key, "volume_cells": len(d), "lose": sum(x < 0 for x in d), "lose_by_over_1db": sum(x < -1 for x in d),
                      "median_db": round(statistics.median(d), 2), "worst_db": round(min(d), 2),
                      "at_10_25_pct_3db_better": f"{sum(x >= 3 for x in middle)} of {len(middle)}",
                      "coarsest_within_1db": f"{sum(x >= -1 for x in coarsest)} of {len(coarsest)}"}))
