#!/usr/bin/env bash
# The tet budget that fits a 100 ms interaction frame: DVR frame times of the 1M blade's
# store built with a small base (--base-tets 10000) and of the 5M store's coarsest level, at
# 1024x768 and 512x384 (6-frame orbits). Writes bench/results/render_budget.json.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake --build --preset release -j "$(nproc)" --target tetrascope > /dev/null
bin=build/release/apps/tetrascope
[[ -d bench/out/blade1m-small-base.mt ]] || $bin preprocess bench/out/blade1m.vtk -o bench/out/blade1m-small-base.mt --base-tets 10000 --force --progress none > /dev/null
printf '{"attribute": "analytic_f", "colormap": "viridis", "opacity": [[-0.38, 0], [0.89, 0.4]]}\n' > bench/out/budget-tf.json
rows=()
for store in bench/out/blade1m-small-base.mt bench/out/blade5m.mt; do
  for budget in 10000 20000 50000; do
    for size in 1024x768 512x384; do
      j=$($bin render "$store" --budget "$budget" --tf bench/out/budget-tf.json --size "$size" --orbit 6 --quality 60 -o bench/out/budget.jpg --json | tail -1)
      rows+=("$(python3 -c "import json,sys; j=json.loads(sys.argv[1]); print(json.dumps({'store': '$(basename "$store")', 'budget': $budget, 'size': '$size', 'tets': j['tets'], 'median_ms': j['median_ms'], 'median_draw_ms': j['median_draw_ms']}))" "$j")")
      echo "${rows[-1]}"
    done
  done
done
python3 - "${rows[@]}" <<'PY'
import json, sys, datetime
json.dump({"date": datetime.date.today().isoformat(), "machine": "2 cores, Mesa llvmpipe", "runs": [json.loads(r) for r in sys.argv[1:]]},
          open("bench/results/render_budget.json", "w"), indent=2)
PY
