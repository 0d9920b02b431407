#!/usr/bin/env bash
# Point-based isosurfaces (§7.2) against marching tetrahedra: 1, 4 and 16 isovalues on the 1M
# and 5M blades (/work/bigdata, made by bench/segment_bench.sh's generator). Both through `tetrascope render` at
# 512x512, same orbit cameras: the frame time is the median over the orbit's frames (the
# first frame builds the triangles or points and is one of ORBIT, so the median is a cached
# frame); PSNR of the points' last frame against marching tets' last frame (lit, opaque). The
# point target is 400K points (the dissertation's figure 7.7), covering splats. Each mesh and
# isovalue count is run RUNS times; medians reported. Writes bench/results/points.json.
#   bench/points_bench.sh [RUNS=2] [ORBIT=5] [MESHES="blade-1m blade-5m"] [POINT_TARGET=400000] [COUNTS="1 4 16"] [OUT=bench/results/points.json]
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-2}
orbit=${2:-5}
meshes=${3:-"blade-1m blade-5m"}
target=${4:-400000}
counts=${5:-"1 4 16"}
result=${6:-bench/results/points.json}
bin=build/release/apps/tetrascope
out=bench/out/points
mkdir -p "$out" bench/results
rows=()
for name in $meshes; do
  mesh=/work/bigdata/$name.vtk
  [ -f "$mesh" ] || { echo "missing $mesh" >&2; continue; }
  info=$("$bin" info "$mesh" --json)
  for n in $counts; do
    # n isovalues regularly spaced inside the first attribute's range (§7.2's v_k)
    read -r attribute iso <<<"$(python3 -c '
import json, sys
j = json.loads(sys.argv[1]); n = int(sys.argv[2])
a = [x for x in j["attributes"] if x.get("components", 1) == 1][0]
lo, hi = a["range"] if "range" in a else (a["min"], a["max"])
print(a["name"], ",".join("%.9g" % (lo + (hi - lo) * k / (n + 1)) for k in range(1, n + 1)))' "$info" "$n")"
    : >"$out/$name.$n.jsonl"
    for ((r = 0; r < runs; ++r)); do
      iso_json=$("$bin" render "$mesh" --mode iso --attribute "$attribute" --iso "$iso" --size 512x512 --orbit "$orbit" -o "$out/$name.$n.iso.png" --json | tail -1)
      pts_json=$("$bin" render "$mesh" --mode points --attribute "$attribute" --iso "$iso" --size 512x512 --orbit "$orbit" -o "$out/$name.$n.points.png" --point-target "$target" \
        --compare "$out/$name.$n.iso.png" --json | tail -1)
      echo "{\"iso\": $iso_json, \"points\": $pts_json}" >>"$out/$name.$n.jsonl"
    done
    rows+=("$(python3 - "$name" "$n" "$attribute" "$out/$name.$n.jsonl" "$target" <<'PY'
import json, statistics, sys
name, n, attribute, path, target = sys.argv[1:]
rows = [json.loads(l) for l in open(path) if l.strip()]
med = lambda f: statistics.median(f(r) for r in rows)
print(json.dumps({
  "mesh": name, "tets": rows[0]["iso"]["tets"], "attribute": attribute, "isovalues": int(n), "runs": len(rows), "frames_per_run": rows[0]["iso"]["frames"],
  "marching_tets": {"triangles": rows[0]["iso"]["iso_triangles"], "median_frame_ms": med(lambda r: r["iso"]["median_ms"]),
                    "median_draw_ms": med(lambda r: r["iso"]["median_draw_ms"])},
  "points": {"target": int(target), "points": rows[0]["points"]["points"], "median_frame_ms": med(lambda r: r["points"]["median_ms"]),
             "median_draw_ms": med(lambda r: r["points"]["median_draw_ms"])},
  "frame_time_ratio_points_over_triangles": med(lambda r: r["points"]["median_ms"] / r["iso"]["median_ms"]),
  "psnr_points_vs_marching_tets_db": med(lambda r: r["points"]["compare_psnr_db"]),
}))
PY
)")
    echo "${rows[-1]}"
  done
done
python3 - "$target" "${rows[@]}" <<'PY' >"$result"
import json, sys, platform, os
print(json.dumps({
  "benchmark": "point isosurfaces (§7.2) vs marching tetrahedra, tetrascope render 512x512, covering splats, %s-point target" % sys.argv[1],
  "machine": platform.node() + ", " + str(os.cpu_count()) + " cores shared with other builds and benchmarks; Mesa llvmpipe (no GPU)",
  "rows": [json.loads(r) for r in sys.argv[2:]]}, indent=1))
PY
echo "wrote $result"
