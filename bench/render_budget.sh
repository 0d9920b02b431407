#!/usr/bin/env bash
# The tet budget that fits a 100 ms interaction frame: DVR frame times of the 1M blade's
# store built with a small base (--base-tets 10000) and of the 5M store (bench/out/blade5m.mt:
# a symlink to an existing store will do) at budgets from 10K to 200K tets, at 512x384 (the
# GL path's two volume methods and the CPU ray caster) and 1024x768 (GL exact and the caster,
# budgets to 50K) (6-frame orbits; wall and process CPU ms a frame). A store that is not there
# is skipped, named. Adds a record to bench/results/render_budget.json.
#   bench/render_budget.sh [STORE ...]   (default: the two stores above)
set -euo pipefail
cd "$(dirname "$0")/.."
cmake --build --preset release -j "$(nproc)" --target tetrascope > /dev/null
bin=build/release/apps/tetrascope
stores=("$@")
if [[ ${#stores[@]} -eq 0 ]]; then
  if [[ ! -d bench/out/blade1m-small-base.mt && -f bench/out/blade1m.vtk ]]; then
    $bin preprocess bench/out/blade1m.vtk -o bench/out/blade1m-small-base.mt --base-tets 10000 --force --progress none > /dev/null
  fi
  stores=(bench/out/blade1m-small-base.mt bench/out/blade5m.mt)
fi
printf '{"attribute": "analytic_f", "colormap": "viridis", "opacity": [[-0.38, 0], [0.89, 0.4]]}\n' > bench/out/budget-tf.json
rows=()
load_before=$(cut -d' ' -f1-3 /proc/loadavg)
for store in "${stores[@]}"; do
  [[ -e $store ]] || { echo "skip $store: not there" >&2; continue; }
  for budget in 10000 20000 50000 100000 200000; do
    for case in 512x384:exact:gl 512x384:projected:gl 512x384:exact:cpu 1024x768:exact:gl 1024x768:exact:cpu; do
      IFS=: read -r size volume backend <<< "$case"
      [[ $size == 1024x768 && $budget -gt 50000 ]] && continue
      j=$($bin render "$store" --budget "$budget" --tf bench/out/budget-tf.json --size "$size" --volume "$volume" --backend "$backend" --orbit 6 --quality 60 -o bench/out/budget.jpg --json | tail -1)
      rows+=("$(python3 -c "import json,sys; j=json.loads(sys.argv[1]); print(json.dumps({'store': '$(basename "$store")', 'budget': $budget, 'size': '$size', 'volume': '$volume', 'backend': j['backend'], 'tets': j['tets'], 'tets_drawn': j['tets_drawn'], 'median_ms': j['median_ms'], 'median_draw_ms': j['median_draw_ms'], 'median_cpu_ms': j['median_cpu_ms']}))" "$j")")
      echo "${rows[-1]}"
    done
  done
done
load_after=$(cut -d' ' -f1-3 /proc/loadavg)
python3 - "$load_before" "$load_after" "$(git rev-parse --short HEAD)" "${rows[@]}" <<'PY'
import json, sys, datetime, pathlib
path = pathlib.Path("bench/results/render_budget.json")
old = json.loads(path.read_text()) if path.exists() else {"records": []}
if "records" not in old:  # the first record, written before the file held several
    old = {"records": [old]}
old["records"].append({"date": datetime.date.today().isoformat(), "commit": sys.argv[3], "machine": "2 cores, Mesa llvmpipe, shared with other builds",
                       "load_average_before": sys.argv[1], "load_average_after": sys.argv[2], "runs": [json.loads(r) for r in sys.argv[4:]]})
path.write_text(json.dumps(old, indent=2))
PY
