#!/usr/bin/env bash
# The tet budget that fits a 100 ms interaction frame: DVR frame times of the 1M blade's
# store built with a small base (--base-tets 10000) and of the 5M store (bench/out/blade5m.mt:
# a symlink to an existing store will do) at budgets from 10K to 200K tets, at 512x384 (both
# volume methods) and 1024x768 (exact, budgets to 50K) (6-frame orbits; wall and process CPU
# ms a frame). Writes bench/results/render_budget.json.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake --build --preset release -j "$(nproc)" --target tetrascope > /dev/null
bin=build/release/apps/tetrascope
[[ -d bench/out/blade1m-small-base.mt ]] || $bin preprocess bench/out/blade1m.vtk -o bench/out/blade1m-small-base.mt --base-tets 10000 --force --progress none > /dev/null
printf '{"attribute": "analytic_f", "colormap": "viridis", "opacity": [[-0.38, 0], [0.89, 0.4]]}\n' > bench/out/budget-tf.json
rows=()
load_before=$(cut -d' ' -f1-3 /proc/loadavg)
for store in bench/out/blade1m-small-base.mt bench/out/blade5m.mt; do
  for budget in 10000 20000 50000 100000 200000; do
    for case in 512x384:exact 512x384:projected 1024x768:exact; do
      size=${case%:*} volume=${case#*:}
      [[ $size == 1024x768 && $budget -gt 50000 ]] && continue
      j=$($bin render "$store" --budget "$budget" --tf bench/out/budget-tf.json --size "$size" --volume "$volume" --orbit 6 --quality 60 -o bench/out/budget.jpg --json | tail -1)
      rows+=("$(python3 -c "import json,sys; j=json.loads(sys.argv[1]); print(json.dumps({'store': '$(basename "$store")', 'budget': $budget, 'size': '$size', 'volume': '$volume', 'tets': j['tets'], 'tets_drawn': j['tets_drawn'], 'median_ms': j['median_ms'], 'median_draw_ms': j['median_draw_ms'], 'median_cpu_ms': j['median_cpu_ms']}))" "$j")")
      echo "${rows[-1]}"
    done
  done
done
load_after=$(cut -d' ' -f1-3 /proc/loadavg)
python3 - "$load_before" "$load_after" "${rows[@]}" <<'PY'
import json, sys, datetime
json.dump({"date": datetime.date.today().isoformat(), "machine": "2 cores, Mesa llvmpipe, shared with other builds",
           "load_average_before": sys.argv[1], "load_average_after": sys.argv[2], "runs": [json.loads(r) for r in sys.argv[3:]]},
          open("bench/results/render_budget.json", "w"), indent=2)
PY
