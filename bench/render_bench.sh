#!/usr/bin/env bash
# Frame times of `tetrascope render --orbit` (DVR and isosurface, 1024x768) on the ~100K, ~1M
# and ~5M-tet turbine blades, next to ParaView 5.11's "Projected tetra" volume rendering
# of the same mesh, size and camera path (bench/paraview_render.py, pvbatch under Xvfb; both
# on Mesa llvmpipe), in one run. Writes bench/results/render.json.
# DVR runs twice: --volume projected (rows "dvr") and --volume exact, the default ("dvr_exact"). Each row also
# has the process CPU time per frame (every thread, llvmpipe's included), which a shared
# machine disturbs less than wall time.
#   bench/render_bench.sh [FRAMES] [MESHES]   (default 36, "100k 1m 5m"; ParaView gets at most 8 frames on 5M tets)
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps --bench > /dev/null
cmake --preset release > /dev/null
cmake --build --preset release -j "$(nproc)" --target tetrascope > /dev/null
frames=${1:-36}
meshes=${2:-100k 1m 5m}
mkdir -p bench/out bench/results
for n in $meshes; do
  mesh="bench/out/blade$n.vtk"
  if [[ ! -s "$mesh" ]]; then
    target=$([[ $n == 100k ]] && echo 100000 || echo $(( ${n%m} * 1000000 )))
    bash ../shared/data/make/make-large.sh "$target" "$(realpath -m "$mesh")" analytic > /dev/null
  fi
done
printf '{"attribute": "analytic_f", "colormap": "viridis", "opacity": [[-1e30, 0], [1e30, 0.4]]}\n' > bench/out/render-tf.json
rows=()
for n in $meshes; do
  mesh="bench/out/blade$n.vtk"
  range=$(build/release/apps/tetrascope info --json "$mesh" | python3 -c 'import json,sys; a=[x for x in json.load(sys.stdin)["attributes"] if x["name"]=="analytic_f"][0]; print(a["min"], a["max"])')
  read -r lo hi <<< "$range"
  printf '{"attribute": "analytic_f", "colormap": "viridis", "opacity": [[%s, 0], [%s, 0.4]]}\n' "$lo" "$hi" > bench/out/render-tf.json
  dvr=$(build/release/apps/tetrascope render "$mesh" -o bench/out/render-$n.jpg --tf bench/out/render-tf.json --size 1024x768 --orbit "$frames" --quality 80 --volume projected --json | tail -1)
  exact=$(build/release/apps/tetrascope render "$mesh" -o bench/out/render-exact-$n.jpg --tf bench/out/render-tf.json --size 1024x768 --orbit "$frames" --quality 80 --volume exact --json | tail -1)
  iso=$(build/release/apps/tetrascope render "$mesh" -o bench/out/render-iso-$n.jpg --mode iso --attribute analytic_f --size 1024x768 --orbit "$frames" --quality 80 --json | tail -1)
  pv_frames=$frames
  [[ $n == 5m ]] && pv_frames=$(( frames < 8 ? frames : 8 ))
  # xvfb-run -a can lose a race for a display with other runs on a shared machine: one retry
  pv=$(xvfb-run -a -s "-screen 0 1280x1024x24" pvbatch bench/paraview_render.py "$mesh" analytic_f 1024 768 "$pv_frames" 2>/dev/null | tail -1) ||
    pv=$(xvfb-run -a -s "-screen 0 1280x1024x24" pvbatch bench/paraview_render.py "$mesh" analytic_f 1024 768 "$pv_frames" 2>/dev/null | tail -1)
  rows+=("$(python3 - "$n" "$dvr" "$iso" "$pv" "$exact" <<'PY'
import json, sys
n, dvr, iso, pv, exact = sys.argv[1], *map(json.loads, sys.argv[2:6])
print(json.dumps({"mesh": "blade" + n, "tets": dvr["tets"], "dvr": dvr, "dvr_exact": exact, "iso": iso, "paraview_projected_tetra": pv,
                  "dvr_speedup_vs_paraview": pv["median_ms"] / dvr["median_ms"], "exact_speedup_vs_paraview": pv["median_ms"] / exact["median_ms"]}))
PY
)")
  echo "${rows[-1]}" | cut -c1-160
done
python3 - "${rows[@]}" <<'PY'
import json, sys, datetime
rows = [json.loads(r) for r in sys.argv[1:]]
json.dump({"date": datetime.date.today().isoformat(), "machine": "2 cores, 24 GB, Debian 12, Mesa llvmpipe, shared with other builds",
           "size": "1024x768", "runs": rows}, open("bench/results/render.json", "w"), indent=2)
print(f"{'mesh':10} {'tets':>9} | {'exact':>7} {'cpu':>7} | {'DVR ms':>7} {'cpu':>7} {'sort':>6} {'draw':>7} {'read':>5} {'enc':>5} {'drawn':>8} | {'iso ms':>7} {'tris':>8} | {'PV ms':>7} {'PV 1st':>7} | {'x PV':>5}")
for r in rows:
    d, i, p = r["dvr"], r["iso"], r["paraview_projected_tetra"]
    e = r["dvr_exact"]
    print(f"{r['mesh']:10} {r['tets']:9} | {e['median_ms']:7.1f} {e['median_cpu_ms']:7.1f} | {d['median_ms']:7.1f} {d['median_cpu_ms']:7.1f} {d['median_sort_ms']:6.1f} {d['median_draw_ms']:7.1f} {d['median_readback_ms']:5.1f} {d['median_encode_ms']:5.1f} {d['tets_drawn']:8} | "
          f"{i['median_ms']:7.1f} {i['iso_triangles']:8} | {p['median_ms']:7.1f} {p['first_frame_ms']:7.1f} | {r['dvr_speedup_vs_paraview']:5.2f}")
PY
