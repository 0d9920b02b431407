#!/usr/bin/env bash
# Whether two builds make the same cuts: `tetrascope cut --json` of each at the fidelity
# bench's budgets, views and transfer functions (5/10/25/50% of the input), on the stores the
# bench left in bench/out/fidelity; prints one JSON line a cut and writes
# bench/results/cut_compare.json. Checks, for instance, that an update from the coarsest
# cut did not change when Cut::update began to queue segments shown in part.
#   OLD=/path/to/older/tetrascope bench/cut_compare.sh
# Env: OLD (required), NEW (default build/release/apps/tetrascope).
set -euo pipefail
cd "$(dirname "$0")/.."
old=${OLD:?give OLD=an older tetrascope binary}
new=${NEW:-build/release/apps/tetrascope}
out=bench/out/fidelity
py=/usr/bin/python3
# case | camera (as bench/fidelity_bench.sh)
cases=(
  "onera-wing-broad|eye=2.2,2.4,1.8,target=0.6,0.7,0,up=0,1,0,fov=40"
  "onera-wing-narrow|eye=2.2,2.4,1.8,target=0.6,0.7,0,up=0,1,0,fov=40"
  "oxygen-post-outside|azimuth=30,elevation=20"
  "oxygen-post-inside|eye=0,-6,2.4,target=0,6,2.4,up=0,0,1,fov=60"
  "bracket-outside|azimuth=30,elevation=20"
  "bracket-inside|eye=0,-1.2,1.6,target=0,2,1.6,up=0,0,1,fov=70"
)
mesh_of() { case "$1" in onera*) echo onera_m6_potential ;; oxygen*) echo nasa_oxygen_post ;; bracket*) echo fea_bracket ;; esac; }
summary() { "$py" -c 'import json,sys; j=json.load(sys.stdin); print(json.dumps({"tets": j["tets"], "estimated_error": j["estimated_error"], "variant_segments": j.get("variant_segments", 0)}))'; }
rows=()
for spec in "${cases[@]}"; do
  IFS='|' read -r name camera <<< "$spec"
  [[ -s "$out/$name.tf.json" ]] || { echo "skip $name: no $out/$name.tf.json (run the fidelity bench first)" >&2; continue; }
  for store in "$out/$(mesh_of "$name")"-*.store; do
    [[ -d "$store" ]] || continue
    input=$("$new" info --json "$store" | "$py" -c 'import json,sys; print(json.load(sys.stdin)["multiresolution"]["levels"][0]["tets"])')  # level 0: the input
    for pct in 5 10 25 50; do
      budget=$((input * pct / 100))
      a=$("$old" cut "$store" --budget "$budget" -o "$out/compare-a.vtk" --camera "$camera" --size 256x192 --tf "$out/$name.tf.json" --json 2> /dev/null | summary)
      b=$("$new" cut "$store" --budget "$budget" -o "$out/compare-b.vtk" --camera "$camera" --size 256x192 --tf "$out/$name.tf.json" --json 2> /dev/null | summary)
      row="{\"case\":\"$name\",\"store\":\"$(basename "$store")\",\"budget\":$budget,\"old\":$a,\"new\":$b,\"same\":$([[ "$a" == "$b" ]] && echo true || echo false)}"
      echo "$row"
      rows+=("$row")
    done
  done
done
"$py" - "$old" "$new" "${rows[@]}" <<'PY'
import datetime, json, sys
rows = [json.loads(r) for r in sys.argv[3:]]
json.dump({"date": datetime.date.today().isoformat(), "old": sys.argv[1], "new": sys.argv[2],
           "method": "tetrascope cut --json (one update from the coarsest cut) with each binary, the fidelity bench's views and transfer functions, budgets 5/10/25/50% of the input",
           "same": sum(r["same"] for r in rows), "cuts": len(rows), "rows": rows}, open("bench/results/cut_compare.json", "w"), indent=1)
print(f"{sum(r['same'] for r in rows)} of {len(rows)} cuts the same")
PY
