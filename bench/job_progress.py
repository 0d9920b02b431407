#!/usr/bin/env python3
"""How `tetrascope preprocess --progress json` reports progress (a job's bar once sat at 10 %
for 12 s, then said "81 s left" for a job that ended at 24 s).

For each mesh: runs preprocess, timestamps every progress line, and reports each stage's share of
the wall time, the longest stretch without the percentage moving, and the ETA's error at 25/50/75 %
of the run. Writes bench/results/job_progress.json.
  bench/job_progress.py [--runs N] [--binary build/release/apps/tetrascope] MESH...
"""
import argparse, json, os, statistics, subprocess, sys, tempfile, time

def one_run(binary, mesh):
    with tempfile.TemporaryDirectory(prefix="tetrascope-progress-") as out:
        start = time.monotonic()
        p = subprocess.Popen([binary, "preprocess", mesh, "-o", os.path.join(out, "s"), "--progress", "json"],
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        lines = []
        for line in p.stdout:
            try:
                j = json.loads(line)
            except ValueError:
                continue
            if isinstance(j, dict) and "percent" in j:
                lines.append((time.monotonic() - start, j))
        p.wait()
        total = time.monotonic() - start
        if p.returncode != 0:
            raise SystemExit(f"{mesh}: preprocess failed")
    stages, order = {}, []
    for t, j in lines:
        s = j["stage"]
        if s not in stages:
            stages[s] = [t, t]
            order.append(s)
        stages[s][1] = t
    # a stage runs from its first line to the next stage's first line
    durations = {}
    for i, s in enumerate(order):
        end = stages[order[i + 1]][0] if i + 1 < len(order) else total
        durations[s] = end - stages[s][0]
    stall, last_t, last_p = 0.0, 0.0, -1.0
    for t, j in lines:
        if j["percent"] != last_p:
            stall = max(stall, t - last_t)
            last_t, last_p = t, j["percent"]
    stall = max(stall, total - last_t)
    eta_error = {}
    for q in (0.25, 0.5, 0.75):
        cands = [(t, j) for t, j in lines if t >= q * total and j.get("eta_s", -1) >= 0]
        if cands:
            t, j = cands[0]
            eta_error[str(q)] = round(j["eta_s"] - (total - t), 2)
    return {"total_s": total, "stage_s": durations, "longest_stall_s": stall,
            "percent_at": {str(q): next((j["percent"] for t, j in lines if t >= q * total), 100.0) for q in (0.25, 0.5, 0.75)},
            "eta_error_s": eta_error}

def main():
    a = argparse.ArgumentParser()
    a.add_argument("--runs", type=int, default=3)
    a.add_argument("--binary", default="build/release/apps/tetrascope")
    a.add_argument("--label", default="")
    a.add_argument("meshes", nargs="+")
    args = a.parse_args()
    out = {"note": "2-core machine shared with other builds; medians of --runs runs", "runs": args.runs, "label": args.label, "meshes": {}}
    for mesh in args.meshes:
        runs = [one_run(args.binary, mesh) for _ in range(args.runs)]
        stages = runs[0]["stage_s"].keys()
        total = statistics.median(r["total_s"] for r in runs)
        med = {s: statistics.median(r["stage_s"].get(s, 0) for r in runs) for s in stages}
        out["meshes"][os.path.basename(mesh)] = {
            "total_s": round(total, 2),
            "stage_s": {s: round(v, 2) for s, v in med.items()},
            "stage_share": {s: round(v / sum(med.values()), 3) for s, v in med.items()},
            "longest_stall_s": round(statistics.median(r["longest_stall_s"] for r in runs), 2),
            "percent_at_quarter_half_three_quarters": [statistics.median(r["percent_at"][q] for r in runs) for q in ("0.25", "0.5", "0.75")],
            "eta_error_s": runs[len(runs) // 2]["eta_error_s"],
        }
        print(os.path.basename(mesh), json.dumps(out["meshes"][os.path.basename(mesh)]), flush=True)
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results", "job_progress.json")
    old = json.load(open(path)) if os.path.exists(path) else {}
    old[args.label or "run"] = out
    json.dump(old, open(path, "w"), indent=1)

if __name__ == "__main__":
    main()
