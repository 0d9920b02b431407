#!/usr/bin/env python3
"""The vertex front's forced splits out of view on the cells of fidelity_random.py records:
for every cell at 5, 10 and 25% showing at least 5% of its pixels, `tetrascope cut --json`
with the cell's camera, transfer function or isovalue and budget, and the share of the
front's tets that are `unseen_tets` (split only because splits in view needed them), by
mesh and by eye. Writes bench/results/front_unseen.json.

    bench/front_unseen.py SEED:WORK [SEED:WORK ...]   (WORK: the record's --work folder, with its stores)
"""
import json
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BINARY = ROOT / "build" / "release" / "apps" / "tetrascope"


def main():
    records = {r["seed"]: r for r in json.loads((ROOT / "bench" / "results" / "fidelity_random.json").read_text())["records"]}
    out = {}
    scratch = ROOT / "bench" / "out"
    scratch.mkdir(parents=True, exist_ok=True)
    for arg in sys.argv[1:]:
        seed, work = arg.split(":", 1)
        record = records[int(seed)]
        rows = []
        for c in record["cells"]:
            if c["coverage"] < 0.05 or c["budget_pct"] not in (5.0, 10.0, 25.0):
                continue
            args = [str(BINARY), "cut", str(Path(work) / c["mesh"].replace(".vtk", ".store")), "-o", str(scratch / "front-unseen.vtk"), "--camera", c["camera"],
                    "--size", record["size"], "--json", "--budget", str(c["budget_tets"])]
            if c["kind"] == "iso":
                args += ["--attribute", c["tf"]["attribute"], "--iso", repr(c["tf"]["iso"])]
            else:
                (scratch / "front-unseen-tf.json").write_text(json.dumps(c["tf"]))
                args += ["--tf", str(scratch / "front-unseen-tf.json")]
            j = json.loads(subprocess.run(args, capture_output=True, text=True, check=True).stdout)
            rows.append({"mesh": c["mesh"], "view": c["view"], "inside": c["inside"], "budget_pct": c["budget_pct"], "tets": j["tets"],
                         "forced_tets": j["forced_tets"], "unseen_tets": j["unseen_tets"]})
        summary = {}
        for mesh in sorted({r["mesh"] for r in rows}):
            for eye in ("inside", "outside"):
                for pct in (5.0, 10.0, 25.0):
                    shares = [r["unseen_tets"] / r["tets"] for r in rows if r["mesh"] == mesh and r["inside"] == (eye == "inside") and r["budget_pct"] == pct]
                    if shares:
                        summary[f"{mesh} {eye} {pct:g}%"] = {"cells": len(shares), "median": statistics.median(shares), "max": max(shares)}
        for key, value in summary.items():
            print(seed, key, "unseen share median %.2f max %.2f (%d cells)" % (value["median"], value["max"], value["cells"]), flush=True)
        out[seed] = {"cells": rows, "unseen_share": summary}
    (ROOT / "bench" / "results" / "front_unseen.json").write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
