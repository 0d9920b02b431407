#!/usr/bin/env bash
# The GL volume rendering against the CPU reference ray caster (`render --reference`) on every
# shared dataset at 512x512: PSNR in dB, for both methods: `--volume exact` (the default; this
# run also writes the reference image) and `--volume projected` (compared with that same
# reference image through --compare, so the reference is computed once). Writes
# bench/results/render_psnr.json.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake --build --preset release -j "$(nproc)" --target tetrascope > /dev/null
mkdir -p bench/out bench/results
rows=()
for mesh in ../shared/data/*.vtk; do
  name=$(basename "${mesh%.vtk}")
  # the first attribute, opacity from 0 at its minimum to 0.3 at its maximum
  build/release/apps/tetrascope info --json "$mesh" | python3 -c 'import json,sys; a=json.load(sys.stdin)["attributes"][0]; lo,hi=(a["min"],a["max"]) if a["components"]==1 else (0,a["max"]); print(json.dumps({"attribute":a["name"],"colormap":"viridis","opacity":[[lo,0],[hi,0.3]]}))' > "bench/out/psnr-$name.json"
  start=$(date +%s)
  j=$(build/release/apps/tetrascope render "$mesh" -o "bench/out/psnr-$name.png" --tf "bench/out/psnr-$name.json" --size 512x512 --volume exact --backend gl --reference --json | tail -1)
  seconds=$(( $(date +%s) - start ))
  p=$(build/release/apps/tetrascope render "$mesh" -o "bench/out/psnr-projected-$name.png" --tf "bench/out/psnr-$name.json" --size 512x512 --volume projected --compare "bench/out/psnr-$name.reference.png" --json | tail -1)
  rows+=("$(python3 -c "import json,sys; j=json.loads(sys.argv[1]); p=json.loads(sys.argv[2]); print(json.dumps({'mesh': '$name', 'tets': j['tets'], 'attribute': j['legend']['attribute'], 'psnr_db': j['reference_psnr_db'], 'gl_ms': j['median_ms'], 'psnr_db_projected': p['compare_psnr_db'], 'gl_ms_projected': p['median_ms'], 'seconds_with_reference': $seconds}))" "$j" "$p")")
  echo "${rows[-1]}"
done
python3 - "${rows[@]}" <<'PY'
import json, sys, datetime
rows = [json.loads(r) for r in sys.argv[1:]]
json.dump({"date": datetime.date.today().isoformat(), "size": "512x512", "camera": "azimuth 30, elevation 20, distance 1.6",
           "transfer_function": "the first attribute (vectors by magnitude), viridis, opacity 0 at its minimum to 0.3 at its maximum, unit distance 1/100 of the diagonal",
           "methods": "psnr_db: --volume exact (default) against the reference; psnr_db_projected: --volume projected against the same reference image",
           "runs": rows}, open("bench/results/render_psnr.json", "w"), indent=2)
PY
