#!/usr/bin/env bash
# Playing a time series in the viewer: a 10-step series on a 1,026,895-tet grid
# (bench/make_series.py 59 10: a pressure wave and a turning vortex, VTK legacy binary files
# and a .pvd), preprocessed once (its time and peak RSS recorded), served by `tetrascope
# serve` and played in headless Chromium as fast as frames come (bench/time_play.mjs: RUNS
# runs of SECONDS each, the median steps a second), at the server's default interaction
# budget and frame time. Writes OUT (default bench/results/time_play.json).
#   bench/time_play.sh [RUNS] [SECONDS] [OUT]
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-3}
seconds=${2:-10}
out=${3:-bench/results/time_play.json}
work=bench/out/time_play
mkdir -p "$work/data" bench/results
[[ -f $work/series/series.pvd ]] || /usr/bin/python3 bench/make_series.py 59 10 "$work/series"
binary=build/release/apps/tetrascope
if [[ ! -f $work/data/wave/manifest.json ]]; then
  /usr/bin/time -v "$binary" preprocess "$work/series/series.pvd" -o "$work/data/wave" --progress none --json > "$work/preprocess.json" 2> "$work/preprocess.time"
fi
load_before=$(cut -d' ' -f1-3 /proc/loadavg)
play=$(node bench/time_play.mjs "$work/data" wave "$runs" "$seconds" | tail -1)
load_after=$(cut -d' ' -f1-3 /proc/loadavg)
/usr/bin/python3 - "$work" "$play" "$load_before" "$load_after" "$out" <<'PY'
import json, os, re, sys
work, play, before, after, out = sys.argv[1:6]
build = json.load(open(work + "/preprocess.json"))
timing = open(work + "/preprocess.time").read()
rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", timing).group(1)) if "Maximum resident" in timing else None
wall = re.search(r"Elapsed \(wall clock\) time.*: (.+)", timing)
result = {
    "benchmark": "a 10-step time series on a 1,026,895-tet grid played in the viewer (headless Chromium, tetrascope serve, one render worker) as fast as frames come",
    "goal": "at least 5 steps a second at the interaction budget",
    "machine": "%d cores, software GL (llvmpipe)" % os.cpu_count(),
    "load_average_before": before, "load_average_after": after,
    "play": json.loads(play),
    "preprocess": {"seconds": build.get("seconds"), "time_steps": build.get("time_steps"), "peak_rss_kib": rss, "wall": wall.group(1) if wall else None},
}
json.dump(result, open(out, "w"), indent=2)
print(json.dumps({"median_steps_per_second": result["play"]["median_steps_per_second"], "runs": result["play"]["runs"]}))
PY
