#!/usr/bin/env bash
# --segment-tets auto: for each mesh, the grading preprocess reads off it (the 90th
# over the 10th percentile of its tets' size), the segment size auto picks, and the build with
# auto beside the build with the other size (8192 or 16384): preprocess wall time and peak RSS,
# store bytes, segments, and the cut update time (bench/cut_bench, 100-step orbit at a budget of
# a fifth of the tets), each the median of REPEATS runs. Writes bench/results/segment_auto.json.
#   bench/segment_auto.sh MESH...      (REPEATS=3)
# OTHER="ARGS" builds the other store with these options instead of the other segment size, and
# RESULT names the JSON: OTHER="--level-ratio 0.25" RESULT=bench/results/level_ratio_auto.json
# sets auto's level ratio (0.5 on a nearly uniform mesh) beside 0.25.
# The fidelity of both sizes is fidelity_bench.sh's (tags mass and seg8k in fidelity.json).
set -euo pipefail
cd "$(dirname "$0")/.."
repeats=${REPEATS:-3}
result=${RESULT:-bench/results/segment_auto.json}
bin=build/release/apps/tetrascope
cmake --build --preset release -j "$(nproc)" --target tetrascope cut_bench > /dev/null
mkdir -p bench/out
rows=()
for mesh in "$@"; do
  name=$(basename "${mesh%.*}")
  for size in auto other; do
    store="bench/out/segauto-$name-$size.mt"
    args=()
    if [[ $size == other && -n "${OTHER:-}" ]]; then
      read -r -a args <<< "$OTHER"
    elif [[ $size == other ]]; then
      chosen=$(python3 -c "import json; print(json.load(open('bench/out/segauto-$name-auto.json'))['segment_tets'])")
      args=(--segment-tets $((chosen == 8192 ? 16384 : 8192)))
    fi
    runs=()
    for ((i = 0; i < repeats; ++i)); do
      /usr/bin/time -f "%M %e" -o "bench/out/segauto.time" $bin preprocess "$mesh" -o "$store" --force --progress none --json "${args[@]}" \
        > "bench/out/segauto-$name-$size.json" 2> /dev/null
      tets=$(python3 -c "import json; print(json.load(open('bench/out/segauto-$name-$size.json'))['input_tets'])")
      cut=$(build/release/bench/cut_bench "$store" --budget $((tets / 5)) --steps 100)
      runs+=("$(cat bench/out/segauto.time) $(python3 -c "import json,sys; print(json.loads(sys.argv[1])['update_ms']['median'])" "$cut")")
    done
    rows+=("$(python3 - "$name" "$size" "bench/out/segauto-$name-$size.json" "${runs[@]}" <<'PY'
import json, statistics, sys
name, size, report = sys.argv[1:4]
runs = [r.split() for r in sys.argv[4:]]
r = json.load(open(report))
med = lambda k: statistics.median(float(x[k]) for x in runs)
print(json.dumps({"mesh": name, "size": size, "grading": round(r["grading"], 2), "segment_tets": r["segment_tets"], "level_ratio": r.get("level_ratio"), "input_tets": r["input_tets"],
                  "segments": r["segments"], "levels": len(r["levels"]), "coarsest_tets": r["levels"][-1]["tets"],
                  "level_tets_over_input": round(sum(l["tets"] for l in r["levels"]) / r["input_tets"], 2), "store_bytes": r["store_bytes"],
                  "bytes_per_tet": round(r["store_bytes"] / r["input_tets"], 1), "wall_seconds": med(1), "peak_rss_mb": round(med(0) / 1024),
                  "cut_update_ms": round(med(2), 4), "runs": len(runs)}))
PY
)")
    echo "${rows[-1]}"
  done
done
python3 - "$result" "${OTHER:-the other --segment-tets}" "${rows[@]}" <<'PY'
import datetime, json, sys
out, other = sys.argv[1:3]
rows = [json.loads(r) for r in sys.argv[3:]]
try:
    old = {(r["mesh"], r["size"]): r for r in json.load(open(out))["runs"]}
except (OSError, ValueError, KeyError):
    old = {}
for r in rows: old[(r["mesh"], r["size"])] = r
json.dump({"date": datetime.date.today().isoformat(), "machine": "2 cores, 24 GB, Debian 12",
           "method": f"preprocess MESH (auto) and with {other} (size 'other'); medians of 'runs' runs: wall seconds, peak RSS, cut_bench --budget tets/5 --steps 100 median update",
           "runs": sorted(old.values(), key=lambda r: (r["mesh"], r["size"]))}, open(out, "w"), indent=1)
print(f"{'mesh':28} {'size':5} {'grading':>7} {'seg tets':>8} {'segs':>5} {'MB':>6} {'B/tet':>6} {'s':>6} {'RSS MB':>6} {'cut ms':>7}")
for r in sorted(old.values(), key=lambda r: (r["mesh"], r["size"])):
    print(f"{r['mesh']:28} {r['size']:5} {r['grading']:7.1f} {r['segment_tets']:8} {r['segments']:5} {r['store_bytes'] / 1e6:6.1f} {r['bytes_per_tet']:6.1f} {r['wall_seconds']:6.1f} {r['peak_rss_mb']:6} {r['cut_update_ms']:7.3f}")
PY
