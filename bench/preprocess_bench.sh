#!/usr/bin/env bash
# The multi-triangulation (§6.3) on the ~1M, ~5M and ~20M-tet turbine blades of
# shared/data/make/make-large.sh: preprocess wall time, tets/s, peak RSS, store size (bytes
# per input tet), levels, segments, patches, average tets per segment and per patch (Table
# 6.7); the cut update time over a 100-step camera orbit and the segment swap rate
# (bench/cut_bench); Ẽ_M^f of the coarsest level and of budgets of 5%, 20% and 50% of the
# tets (`tetrascope cut` + `tetrascope error`; on the 1M and 5M meshes - measuring the 20M
# one takes longer than the preprocessing). Writes bench/results/preprocess.json.
#   bench/preprocess_bench.sh [MESH...]
#   bench/preprocess_bench.sh --sample [MESH [REPEATS]]  (METHODS="sample": only that one)   --simplifier sample against qem,
#                                                      bench/preprocess_sample_compare.sh
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ "${1:-}" == "--sample" ]]; then
  shift
  exec bash bench/preprocess_sample_compare.sh "$@"
fi
scripts/install-deps --bench > /dev/null
cmake --preset release > /dev/null
cmake --build --preset release -j "$(nproc)" --target tetrascope cut_bench > /dev/null
mkdir -p bench/out bench/results
meshes=("$@")
if ((${#meshes[@]} == 0)); then
  for n in 1m 5m 20m; do
    mesh="bench/out/blade$n.vtk"
    if [[ ! -s "$mesh" ]]; then
      echo "generating $mesh"
      bash ../shared/data/make/make-large.sh "$(( ${n%m} * 1000000 ))" "$(realpath -m "$mesh")" analytic > /dev/null
    fi
    meshes+=("$mesh")
  done
fi
bin=build/release/apps/tetrascope
rows=()
for mesh in "${meshes[@]}"; do
  name=$(basename "${mesh%.*}")
  store="bench/out/$name.mt"
  log="$(mktemp)"
  /usr/bin/time -f "%M %e" -o "$log" $bin preprocess "$mesh" -o "$store" --force --progress none --json > "$log.json"
  verify=$($bin verify "$store" --progress none --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["ok"])')
  tets=$(python3 -c "import json; print(json.load(open('$log.json'))['input_tets'])")
  cut=$(build/release/bench/cut_bench "$store" --budget $(( tets / 5 )) --steps 100)
  errors="{}"
  if (( tets < 10000000 )); then
    errors="{"
    for share in coarsest 0.05 0.2 0.5; do
      budget=1
      [[ $share != coarsest ]] && budget=$(python3 -c "print(int($tets * $share))")
      $bin cut "$store" --budget "$budget" -o "bench/out/$name.cut.vtk" --json > "$log.cut"
      e=$($bin error "$mesh" "bench/out/$name.cut.vtk" --json)
      errors+="\"$share\": {\"cut\": $(cat "$log.cut"), \"error\": $e},"
    done
    errors="${errors%,}}"
    rm -f "bench/out/$name.cut.vtk"
  fi
  rows+=("$(python3 - "$mesh" "$log" "$verify" "$cut" "$errors" <<'PY'
import json, os, sys
mesh, log, verify, cut, errors = sys.argv[1:6]
r = json.load(open(log + ".json"))
rss_kb, wall = open(log).read().split()
segments = r["segments"]
patches = r["patches"]
stored_tets = sum(l["tets"] for l in r["levels"])
row = {"mesh": os.path.basename(mesh), "input_tets": r["input_tets"], "input_vertices": r["input_vertices"],
       "wall_seconds": float(wall), "tets_per_second": r["input_tets"] / float(wall), "peak_rss_mb": int(rss_kb) / 1024,
       "store_bytes": r["store_bytes"], "bytes_per_input_tet": r["store_bytes"] / r["input_tets"],
       "levels": len(r["levels"]), "segments": segments, "patches": patches,
       "avg_tets_per_segment": stored_tets / segments, "avg_tets_per_patch": stored_tets / patches,
       "base_tets": r["levels"][-1]["tets"], "per_level": r["levels"], "stage_seconds": r["stage_seconds"],
       "verify_ok": verify == "True", "cut": json.loads(cut), "field_error": {}}
for share, e in json.loads(errors).items():
    f = e["error"]["fields"][0]
    row["field_error"][share] = {"tets": e["cut"]["tets"], "mean_field_error": f["mean_field_error"], "max_field_error": f["max_field_error"],
                                 "hausdorff_relative": e["error"]["domain_error"]["hausdorff_relative"]}
print(json.dumps(row))
PY
)")
  echo "${rows[-1]}" | cut -c1-200
  rm -f "$log" "$log.json" "$log.cut"
done
python3 - "${rows[@]}" <<'PY'
import json, sys, datetime
rows = [json.loads(r) for r in sys.argv[1:]]
json.dump({"date": datetime.date.today().isoformat(), "machine": "2 cores, 24 GB, Debian 12",
           "command": "tetrascope preprocess MESH -o STORE (defaults: --segment-tets auto and --level-ratio auto, on these nearly uniform blades 16384 tets a segment and a level ratio of 0.5 (0.25 before --level-ratio auto), levels at a common error, at least 2 segments a level, base 10K tets, 256 bins, 2 threads, cut-border compressed segments); cut_bench --budget tets/5 --steps 100",
           "runs": rows}, open("bench/results/preprocess.json", "w"), indent=2)
print(f"{'mesh':10} {'tets':>10} {'s':>7} {'tets/s':>8} {'RSS MB':>7} {'B/tet':>6} {'levels':>6} {'segs':>5} {'patches':>7} {'tets/seg':>8} {'tets/patch':>10} {'cut ms':>7} {'swap Mt/s':>9}")
for r in rows:
    print(f"{r['mesh']:10} {r['input_tets']:10} {r['wall_seconds']:7.1f} {r['tets_per_second']:8.0f} {r['peak_rss_mb']:7.0f} {r['bytes_per_input_tet']:6.1f} {r['levels']:6} "
          f"{r['segments']:5} {r['patches']:7} {r['avg_tets_per_segment']:8.0f} {r['avg_tets_per_patch']:10.0f} {r['cut']['update_ms']['median']:7.3f} {r['cut']['swap']['tets_per_second'] / 1e6:9.1f}")
PY
