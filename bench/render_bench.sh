#!/usr/bin/env bash
# Frame times of `tetrascope render --orbit` (DVR and isosurface, 1024x768) on small shared
# meshes (disk_out_ref, fea_bracket: under 100K tets) and the ~100K (337K tets), ~1M and ~5M-tet
# turbine blades, next to ParaView 5.11's "Projected tetra" volume rendering of the same mesh,
# attribute, size and camera path (bench/paraview_render.py, pvbatch under Xvfb; both on Mesa
# llvmpipe), and the raw triangle ceiling of the same triangles (bench/triangle_ceiling.cpp:
# the triangles each DVR method emits for each orbit frame, at their mean pixel area, drawn
# with a constant-colour shader into the same float target with the same blending), in one
# run. Writes OUT (default bench/results/render.json).
# DVR runs three times: --volume projected (rows "dvr"), --volume exact (rows "dvr_exact"; both --backend gl),
# and the CPU ray caster, --backend cpu ("dvr_cpu"). Each row also
# has the process CPU time per frame (every thread, llvmpipe's included), which a shared
# machine disturbs less than wall time.
#   bench/render_bench.sh [FRAMES] [MESHES] [OUT]   (default 36, "disk_out_ref fea_bracket 100k 1m 5m";
#   ParaView gets at most 6 frames on 5M tets). TETRASCOPE_BUILD=DIR takes tetrascope and
#   triangle_ceiling from an existing build folder DIR as they are (default: build/release,
#   configured and built by the release preset first). A blade bench/out/bladeN.vtk is made by
#   make-large.sh when missing (a symlink to an existing one will do); other names are
#   ../shared/data/NAME.vtk, rendered by their first attribute.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${TETRASCOPE_BUILD:-build/release}
if [[ -z ${TETRASCOPE_BUILD:-} ]]; then
  scripts/install-deps --bench > /dev/null
  cmake --preset release > /dev/null
  cmake --build --preset release -j "$(nproc)" --target tetrascope triangle_ceiling > /dev/null
fi
frames=${1:-36}
meshes=${2:-disk_out_ref fea_bracket 100k 1m 5m}
out=${3:-bench/results/render.json}
load_before=$(cut -d' ' -f1-3 /proc/loadavg)
mkdir -p bench/out bench/results
mesh_path() { if [[ $1 =~ ^[0-9]+[km]$ ]]; then echo "bench/out/blade$1.vtk"; else echo "../shared/data/$1.vtk"; fi; }
mesh_name() { if [[ $1 =~ ^[0-9]+[km]$ ]]; then echo "blade$1"; else echo "$1"; fi; }
for n in $meshes; do
  mesh=$(mesh_path "$n")
  if [[ ! -s "$mesh" && $n =~ ^[0-9]+[km]$ ]]; then
    target=$([[ $n == 100k ]] && echo 100000 || echo $(( ${n%m} * 1000000 )))
    bash ../shared/data/make/make-large.sh "$target" "$(realpath -m "$mesh")" analytic > /dev/null
  fi
done
rows=()
for n in $meshes; do
  mesh=$(mesh_path "$n")
  # the blades' analytic_f, else the first attribute; opacity 0 to 0.4 over its range
  info=$("$build"/apps/tetrascope info --json "$mesh" | python3 -c 'import json,sys; at=json.load(sys.stdin)["attributes"]; a=([x for x in at if x["name"]=="analytic_f"] or at)[0]; print(a["name"], a["min"], a["max"])')
  read -r attribute lo hi <<< "$info"
  printf '{"attribute": "%s", "colormap": "viridis", "opacity": [[%s, 0], [%s, 0.4]]}\n' "$attribute" "$lo" "$hi" > bench/out/render-tf.json
  dvr=$("$build"/apps/tetrascope render "$mesh" -o bench/out/render-$n.jpg --tf bench/out/render-tf.json --size 1024x768 --orbit "$frames" --quality 80 --volume projected --backend gl --json | tail -1)
  exact=$("$build"/apps/tetrascope render "$mesh" -o bench/out/render-exact-$n.jpg --tf bench/out/render-tf.json --size 1024x768 --orbit "$frames" --quality 80 --volume exact --backend gl --json | tail -1)
  cpu=$("$build"/apps/tetrascope render "$mesh" -o bench/out/render-cpu-$n.jpg --tf bench/out/render-tf.json --size 1024x768 --orbit "$frames" --quality 80 --backend cpu --json | tail -1)
  iso=$("$build"/apps/tetrascope render "$mesh" -o bench/out/render-iso-$n.jpg --mode iso --attribute "$attribute" --size 1024x768 --orbit "$frames" --quality 80 --json | tail -1)
  pv_frames=$frames
  [[ $n == 5m ]] && pv_frames=$(( frames < 6 ? frames : 6 ))
  ceiling=$("$build"/bench/triangle_ceiling "$mesh" 1024x768 "$frames" 2>/dev/null | tail -1)
  # xvfb-run -a can lose a race for a display with other runs on a shared machine: up to 3
  # tries, each on a display number of its own (-n); a mesh whose ParaView run still fails is
  # left out with a message
  pv=""
  for try in 1 2 3; do
    pv=$(xvfb-run -n $(( 200 + RANDOM % 500 )) -s "-screen 0 1280x1024x24" pvbatch bench/paraview_render.py "$mesh" "$attribute" 1024 768 "$pv_frames" 2>bench/out/paraview-$n.log | tail -1) && break
    pv=""
    sleep 5
  done
  if [[ -z $pv ]]; then
    echo "ParaView failed on $mesh three times (bench/out/paraview-$n.log); left out" >&2
    continue
  fi
  rows+=("$(python3 - "$(mesh_name "$n")" "$dvr" "$iso" "$pv" "$exact" "$ceiling" "$cpu" <<'PY'
import json, sys
n, dvr, iso, pv, exact, ceiling, cpu = sys.argv[1], *map(json.loads, sys.argv[2:8])
# the ceiling draws every tet's triangles; the DVR skips the tets the transfer function leaves transparent
ce = ceiling["exact"]["median_ms"] * exact["tets_drawn"] / exact["tets"]
cp = ceiling["projected"]["median_ms"] * dvr["tets_drawn"] / dvr["tets"]
print(json.dumps({"mesh": n, "tets": dvr["tets"], "dvr": dvr, "dvr_exact": exact, "iso": iso, "paraview_projected_tetra": pv, "triangle_ceiling": ceiling,
                  "dvr_speedup_vs_paraview": pv["median_ms"] / dvr["median_ms"], "exact_speedup_vs_paraview": pv["median_ms"] / exact["median_ms"],
                  # the CPU ray caster (render --backend cpu) on the same frames
                  "dvr_cpu": cpu, "cpu_speedup_vs_paraview": pv["median_ms"] / cpu["median_ms"], "cpu_speedup_vs_gl_exact": exact["median_ms"] / cpu["median_ms"],
                  "exact_draw_vs_ceiling": exact["median_draw_ms"] / ce, "projected_draw_vs_ceiling": dvr["median_draw_ms"] / cp,
                  "exact_frame_vs_ceiling": exact["median_ms"] / ce, "projected_frame_vs_ceiling": dvr["median_ms"] / cp,
                  # process CPU a frame (the whole frame) against the ceiling's CPU for its draw
                  "exact_cpu_vs_ceiling_cpu": exact["median_cpu_ms"] / (ceiling["exact"]["median_cpu_ms"] * exact["tets_drawn"] / exact["tets"]),
                  "projected_cpu_vs_ceiling_cpu": dvr["median_cpu_ms"] / (ceiling["projected"]["median_cpu_ms"] * dvr["tets_drawn"] / dvr["tets"])}))
PY
)")
  echo "${rows[-1]}" | cut -c1-160
  printf '%s\n' "${rows[@]}" > "$out.partial"
done
load_after=$(cut -d' ' -f1-3 /proc/loadavg)
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
python3 - "$out" "$frames" "$load_before" "$load_after" "$commit" "${rows[@]}" <<'PY'
import json, sys, datetime
out, frames, load_before, load_after, commit = sys.argv[1:6]
rows = [json.loads(r) for r in sys.argv[6:]]
json.dump({"date": datetime.date.today().isoformat(), "commit": commit, "machine": "2 cores, 24 GB, Debian 12, Mesa llvmpipe, shared with other builds",
           "load_average_before": load_before, "load_average_after": load_after,
           "size": "1024x768", "frames": int(frames), "runs": rows}, open(out, "w"), indent=2)
print(f"{'mesh':10} {'tets':>9} | {'raycast':>7} {'xPV':>5} {'xGL':>5} | {'exact':>7} {'cpu':>7} | {'DVR ms':>7} {'cpu':>7} {'sort':>6} {'draw':>7} {'read':>5} {'enc':>5} {'drawn':>8} | {'iso ms':>7} {'tris':>8} | {'PV ms':>7} {'PV 1st':>7} | {'x PV':>5} {'exPV':>5} | {'ceilE':>7} {'ceilP':>7} {'E/ce':>5} {'P/ce':>5}")
for r in rows:
    d, i, p = r["dvr"], r["iso"], r["paraview_projected_tetra"]
    e = r["dvr_exact"]
    print(f"{r['mesh']:10} {r['tets']:9} | {r['dvr_cpu']['median_ms']:7.1f} {r['cpu_speedup_vs_paraview']:5.2f} {r['cpu_speedup_vs_gl_exact']:5.2f} | {e['median_ms']:7.1f} {e['median_cpu_ms']:7.1f} | {d['median_ms']:7.1f} {d['median_cpu_ms']:7.1f} {d['median_sort_ms']:6.1f} {d['median_draw_ms']:7.1f} {d['median_readback_ms']:5.1f} {d['median_encode_ms']:5.1f} {d['tets_drawn']:8} | "
          f"{i['median_ms']:7.1f} {i['iso_triangles']:8} | {p['median_ms']:7.1f} {p['first_frame_ms']:7.1f} | {r['dvr_speedup_vs_paraview']:5.2f} {r['exact_speedup_vs_paraview']:5.2f} | "
          f"{r['triangle_ceiling']['exact']['median_ms']:7.1f} {r['triangle_ceiling']['projected']['median_ms']:7.1f} {r['exact_draw_vs_ceiling']:5.2f} {r['projected_draw_vs_ceiling']:5.2f}")
PY
