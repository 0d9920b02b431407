#!/usr/bin/env bash
# The CPU ray caster's scaling with cores: `render --backend cpu --threads T` for T = 1 .. every
# core, on an orbit of FRAMES frames at 1024x768 (opacity 0 to 0.4 over the first attribute, as
# bench/render_bench.sh), REPEAT runs each, alternating the thread counts; the median frame of
# each run, the median of the runs, and the speed-up over one thread.
#   bench/raycast_threads.sh [MESHES] [FRAMES] [REPEAT]   (default "disk_out_ref onera_m6_potential
#   nasa_oxygen_post" from ../shared/data, 6 frames, 3 runs; a path to a .vtk or a store works too)
# TETRASCOPE_BUILD=DIR takes the binary from DIR (default build/release). Adds a record to
# bench/results/raycast_threads.json.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${TETRASCOPE_BUILD:-build/release}/apps/tetrascope
meshes=${1:-disk_out_ref onera_m6_potential nasa_oxygen_post}
frames=${2:-6}
repeat=${3:-3}
cores=$(nproc)
mkdir -p bench/out bench/results
rows=()
for m in $meshes; do
  path=$m
  [[ -e $path ]] || path=../shared/data/$m.vtk
  [[ -e $path ]] || { echo "skip $m: not there" >&2; continue; }
  attribute=$($bin info "$path" --json | python3 -c "import json,sys; a=json.load(sys.stdin)['attributes'][0]; print(a['name'], a['min'], a['max'])")
  read -r name lo hi <<< "$attribute"
  printf '{"attribute": "%s", "colormap": "viridis", "opacity": [[%s, 0], [%s, 0.4]]}\n' "$name" "$lo" "$hi" > bench/out/threads-tf.json
  for ((r = 0; r < repeat; ++r)); do
    for ((t = 1; t <= cores; ++t)); do
      j=$($bin render "$path" -o bench/out/threads.png --tf bench/out/threads-tf.json --size 1024x768 --orbit "$frames" --backend cpu --threads "$t" --json | tail -1)
      rows+=("$(python3 -c "import json,sys; j=json.loads(sys.argv[1]); print(json.dumps({'mesh': '$(basename "$m" .vtk)', 'run': $r, 'threads': $t, 'median_ms': j['median_ms'], 'median_cpu_ms': j['median_cpu_ms'], 'tets': j['tets']}))" "$j")")
      echo "${rows[-1]}"
    done
  done
done
python3 - "$(cut -d' ' -f1-3 /proc/loadavg)" "$(git rev-parse --short HEAD)" "$cores" "$frames" "${rows[@]}" <<'PY'
import datetime, json, pathlib, statistics, sys
load, commit, cores, frames = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
runs = [json.loads(r) for r in sys.argv[5:]]
summary = []
for mesh in dict.fromkeys(r["mesh"] for r in runs):
    ms = {t: statistics.median(r["median_ms"] for r in runs if r["mesh"] == mesh and r["threads"] == t) for t in range(1, cores + 1)}
    summary.append({"mesh": mesh, "median_ms": ms, "speedup": {t: ms[1] / ms[t] for t in ms}})
path = pathlib.Path("bench/results/raycast_threads.json")
old = json.loads(path.read_text()) if path.exists() else {"records": []}
old["records"].append({"date": datetime.date.today().isoformat(), "commit": commit, "cores": cores, "frames": frames, "load_after": load,
                       "method": "render --backend cpu --threads T, 1024x768, median frame of an orbit, median of the runs", "summary": summary, "runs": runs})
path.write_text(json.dumps(old, indent=1))
print(json.dumps(summary))
PY
