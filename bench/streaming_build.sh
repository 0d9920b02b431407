#!/usr/bin/env bash
# The streaming build: `tetrascope preprocess MESH` with each --memory-mb of
# BUDGETS (0 = nothing spilled, the whole build in memory; the default 2048; small budgets
# spill every level but the coarsest), RUNS runs each: wall time, peak RSS (/usr/bin/time),
# CPU seconds, the bytes spilled, the store's bytes; every store compared byte for byte with
# the first budget's and run through verify. Stores go to a temporary folder beside OUT,
# removed at the end. Writes bench/results/streaming_build-NAME.json.
#   bench/streaming_build.sh MESH [NAME]      BUDGETS="0 2048 64" RUNS=1
set -euo pipefail
cd "$(dirname "$0")/.."
mesh="${1:?mesh}"
name="${2:-$(basename "${mesh%.*}")}"
budgets="${BUDGETS:-0 2048 64}"
runs="${RUNS:-1}"
bin="${BIN:-build/release/apps/tetrascope}"
work="${WORK:-$(dirname "$mesh")}/streaming-build.$$"
mkdir -p "$work"
trap 'rm -rf "$work"' EXIT
rows="$work/rows.jsonl"
: > "$rows"
first=""
for run in $(seq "$runs"); do
  for mb in $budgets; do
    store="$work/store-$mb"
    load=$(cut -d' ' -f1 /proc/loadavg)
    /usr/bin/time -f '%e %M %U %S' -o "$work/time" "$bin" preprocess "$mesh" -o "$store" --memory-mb "$mb" --force --progress none --json > "$work/report.json"
    read -r wall rss user sys < "$work/time"
    [[ -z "$first" ]] && { first="$work/first"; rm -rf "$first"; cp -r "$store" "$first"; }
    same=true
    for f in segments.bin dag.bin manifest.json; do cmp -s "$first/$f" "$store/$f" || same=false; done
    verify=false
    "$bin" verify "$store" > /dev/null 2>&1 && verify=true
    python3 - "$work/report.json" "$mb" "$run" "$wall" "$rss" "$user" "$sys" "$same" "$verify" "$load" >> "$rows" << 'PY'
import json, sys
r = json.load(open(sys.argv[1]))
mb, run, wall, rss, user, sys_s, same, verify, load = sys.argv[2:]
print(json.dumps({"memory_mb": int(mb), "run": int(run), "wall_seconds": float(wall), "peak_rss_mb": int(rss) / 1024,
                  "cpu_seconds": float(user) + float(sys_s), "spilled_mb": r["spilled_bytes"] / 2**20, "store_bytes": r["store_bytes"],
                  "bytes_per_input_tet": r["store_bytes"] / r["input_tets"], "input_tets": r["input_tets"], "input_vertices": r["input_vertices"],
                  "levels": [l["tets"] for l in r["levels"]], "stage_seconds": r["stage_seconds"],
                  "same_bytes_as_first_budget": same == "true", "verify_ok": verify == "true", "load_average_before": float(load)}))
PY
    tail -1 "$rows"
    rm -rf "$store"
  done
done
python3 - "$rows" "$mesh" "$runs" > "bench/results/streaming_build-$name.json" << 'PY'
import json, statistics, sys, datetime
rows = [json.loads(l) for l in open(sys.argv[1])]
by = {}
for r in rows: by.setdefault(r["memory_mb"], []).append(r)
med = lambda xs: statistics.median(xs)
summary = [{"memory_mb": mb, "runs": len(rs), "median_wall_seconds": med([r["wall_seconds"] for r in rs]),
            "median_peak_rss_mb": med([r["peak_rss_mb"] for r in rs]), "median_cpu_seconds": med([r["cpu_seconds"] for r in rs]),
            "spilled_mb": rs[0]["spilled_mb"], "all_same_bytes": all(r["same_bytes_as_first_budget"] for r in rs),
            "all_verify_ok": all(r["verify_ok"] for r in rs)} for mb, rs in by.items()]
print(json.dumps({"date": datetime.date.today().isoformat(), "machine": "2 cores, 24 GB, Debian 12 (shared with other work)",
                  "mesh": sys.argv[2], "input_tets": rows[0]["input_tets"], "input_vertices": rows[0]["input_vertices"],
                  "command": "tetrascope preprocess MESH -o STORE --memory-mb M (other options default)",
                  "summary": summary, "runs": rows}, indent=1))
PY
echo "bench/results/streaming_build-$name.json"
