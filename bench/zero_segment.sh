#!/usr/bin/env bash
# Segment exchange on stores of either model: bench/zero_segment_bench over a 40-step camera
# orbit at a budget of 20% of the input, REPEATS times a store (default 3), the median of each
# figure kept: the cut update, the swaps through the 0-segment, the same front docked from
# scratch, the cut mesh assembled with and without its adjacency; and cut_bench's swap rate
# (every segment mapped and validated from a warm page cache, tets a second). Appends to
# bench/results/binary_hierarchy.json ("exchange").
#   bench/zero_segment.sh STORE...
set -euo pipefail
cd "$(dirname "$0")/.."
bench=${ZERO_SEGMENT_BENCH:-build/release/bench/zero_segment_bench}
cut_bench=${CUT_BENCH:-build/release/bench/cut_bench}
repeats=${REPEATS:-3}
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
runs=()
for store in "$@"; do
  for ((r = 0; r < repeats; ++r)); do
    zero=$("$bench" "$store")
    map=$("$cut_bench" "$store" --steps 40)
    runs+=("$(/usr/bin/python3 -c 'import json,sys; z=json.loads(sys.argv[1]); c=json.loads(sys.argv[2]); z["map_tets_per_second"]=c["swap"]["tets_per_second"]; print(json.dumps(z))' "$zero" "$map")")
  done
done
/usr/bin/python3 - "$repeats" "$commit" "${runs[@]}" <<'PY'
import datetime, json, os, statistics, sys
repeats, commit = int(sys.argv[1]), sys.argv[2]
runs = [json.loads(r) for r in sys.argv[3:]]
rows = []
for i in range(0, len(runs), repeats):
    group = runs[i:i + repeats]
    first = group[0]
    med = lambda f: statistics.median(f(g) for g in group)
    row = {k: first[k] for k in ("store", "model", "input_tets", "segments", "patches", "budget", "steps", "steps_that_swapped", "patches_swapped_per_swapping_step", "zero_segment")}
    row["median_ms"] = {k: med(lambda g: g["median_ms"][k]) for k in first["median_ms"]}
    row["swaps_per_second"] = {k: med(lambda g: g["swaps_per_second"][k]) for k in first["swaps_per_second"]}
    row["tets_swapped_per_second_zero_segment"] = med(lambda g: g["tets_swapped_per_second_zero_segment"])
    row["map_tets_per_second"] = med(lambda g: g["map_tets_per_second"])
    row["store"] = os.path.basename(os.path.normpath(row["store"]))
    row["zero_segment"]["build_ms"] = med(lambda g: g["zero_segment"]["build_ms"])
    row["runs"] = len(group)
    row["commit"] = commit
    print(json.dumps(row))
    rows.append(row)
path = "bench/results/binary_hierarchy.json"
old = json.load(open(path)) if os.path.exists(path) else {}
keys = {r["store"] for r in rows}
old["exchange"] = [r for r in old.get("exchange", []) if r["store"] not in keys] + rows
old["exchange_method"] = "bench/zero_segment.sh: zero_segment_bench, 40-step orbit (azimuth 0-360, elevation 20, distance 0.5, fov 30), budget 20% of the input, segments kept mapped; each figure the median over the steps, then over `runs` runs; adjacency_rebuild = assemble with adjacency - without (medians); 2-core machine shared with other jobs"
old["date"] = datetime.date.today().isoformat()
json.dump(old, open(path, "w"), indent=1)
PY
