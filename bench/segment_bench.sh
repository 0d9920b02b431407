#!/usr/bin/env bash
# Segmentation (§6.1) on the ~1M, ~5M and ~20M-tet turbine blades of
# shared/data/make/make-large.sh (analytic field): wall time, tets/s, peak RSS, balance
# (Table 6.3) and the maximal streaming workload (Table 6.4). Writes
# bench/results/segmentation.json. Meshes are generated into bench/out/ when missing
# (1M: ~15 s, 5M: ~1.5 min, 20M: ~6 min and 6 GB of RAM).
#   bench/segment_bench.sh [MESH...]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps --bench > /dev/null
cmake --preset release > /dev/null
cmake --build --preset release -j "$(nproc)" --target tetrascope > /dev/null
mkdir -p bench/out bench/results
meshes=("$@")
if ((${#meshes[@]} == 0)); then
  for n in 1m 5m 20m; do
    mesh="bench/out/blade$n.vtk"
    if [[ ! -s "$mesh" ]]; then
      target=$(( ${n%m} * 1000000 ))
      echo "generating $mesh"
      bash ../shared/data/make/make-large.sh "$target" "$(realpath -m "$mesh")" analytic > /dev/null
    fi
    meshes+=("$mesh")
  done
fi
rows=()
for mesh in "${meshes[@]}"; do
  store="bench/out/$(basename "${mesh%.*}").store"
  log="$(mktemp)"
  /usr/bin/time -f "%M %e" -o "$log" build/release/apps/tetrascope segment "$mesh" -o "$store" --force --progress none --json > "$log.json"
  verify="$(build/release/apps/tetrascope verify "$store" --progress none --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["ok"])')"
  rows+=("$(python3 - "$mesh" "$log" "$verify" <<'PY'
import json, os, sys
mesh, log, verify = sys.argv[1:4]
r = json.load(open(log + ".json"))
rss_kb, wall = open(log).read().split()
r.update({"mesh": os.path.basename(mesh), "mesh_bytes": os.path.getsize(mesh), "peak_rss_mb": int(rss_kb) / 1024,
          "wall_seconds": float(wall), "tets_per_second": r["tetrahedra"] / float(wall), "verify_ok": verify == "True"})
print(json.dumps(r))
PY
)")
  rm -f "$log" "$log.json"
done
python3 - "${rows[@]}" <<'PY'
import json, sys, datetime
rows = [json.loads(r) for r in sys.argv[1:]]
out = {"date": datetime.date.today().isoformat(), "machine": "2 cores, 24 GB, Debian 12",
       "command": "tetrascope segment MESH -o STORE (defaults: 16384 tets a segment, automatic leaf size)", "runs": rows}
json.dump(out, open("bench/results/segmentation.json", "w"), indent=2)
print(f"{'mesh':16} {'tets':>10} {'segs':>5} {'s':>7} {'Mtets/s':>8} {'RSS MB':>7} {'verts/seg min/avg/max':>24} {'tets/seg min/avg/max':>24} {'max/avg':>7} {'workload':>9}")
for r in rows:
    v, t = r["vertices_per_segment"], r["tets_per_segment"]
    print(f"{r['mesh']:16} {r['tetrahedra']:>10} {r['segments']:>5} {r['wall_seconds']:7.2f} {r['tets_per_second']/1e6:8.2f} {r['peak_rss_mb']:7.0f} "
          f"{v['min']:>7}/{v['avg']:>7.0f}/{v['max']:>7} {t['min']:>7}/{t['avg']:>7.0f}/{t['max']:>7} {r['max_tets_over_avg']:7.2f} "
          f"{100*r['max_workload_fraction']:8.1f}%  verify={'ok' if r['verify_ok'] else 'FAILED'}")
PY
