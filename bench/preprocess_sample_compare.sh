#!/usr/bin/env bash
# The body of `bench/preprocess_bench.sh --sample MESH [REPEATS]`: preprocess with
# --simplifier qem and --simplifier sample (both cores), tets/s (median of REPEATS), verify,
# and the coarsest level rendered (--budget 1, 512x512, DVR of the first attribute) against the
# full-resolution mesh's image: PSNR in dB of each store. Writes bench/results/preprocess_sample.json.
set -euo pipefail
trap 'echo "preprocess_sample_compare.sh: failed at line $LINENO (exit $?)" >&2' ERR
cd "$(dirname "$0")/.."
mesh=${1:-/work/bigdata/blade-1m.vtk}
repeats=${2:-1}
bin=build/release/apps/tetrascope
out=bench/out/preprocess_sample
mkdir -p "$out" bench/results
name=$(basename "${mesh%.vtk}")
$bin info --json "$mesh" | python3 -c 'import json,sys; a=json.load(sys.stdin)["attributes"][0]; lo,hi=(a["min"],a["max"]) if a["components"]==1 else (0,a["max"]); print(json.dumps({"attribute":a["name"],"colormap":"viridis","opacity":[[lo,0],[hi,0.3]]}))' > "$out/tf.json"
$bin render "$mesh" -o "$out/full.png" --tf "$out/tf.json" --size 512x512 > /dev/null
rows=()
for method in ${METHODS:-qem sample}; do
  runs=()
  for ((r = 0; r < repeats; ++r)); do
    log=$(mktemp)
    /usr/bin/time -f '%e %U %M' -o "$log" $bin preprocess "$mesh" -o "$out/$name.$method.mt" --simplifier "$method" --threads 2 --force --progress none --json > "$log.json"
    runs+=("$(python3 -c "import json; w,u,m=open('$log').read().split()[-3:]; r=json.load(open('$log.json')); print(json.dumps({'wall':float(w),'user':float(u),'peak_rss_mb':int(m)/1024,'report':r}))")")
    rm -f "$log" "$log.json"
  done
  verify=$($bin verify "$out/$name.$method.mt" --progress none --json | python3 -c 'import json,sys; print(str(json.load(sys.stdin)["ok"]).lower())')
  $bin render "$out/$name.$method.mt" -o "$out/$method.coarsest.png" --tf "$out/tf.json" --size 512x512 --budget 1 > /dev/null
  psnr=$(/usr/bin/python3 bench/psnr.py "$out/full.png" "$out/$method.coarsest.png")
  printf '%s\n' "${runs[@]}" > "$out/$method.runs.jsonl"
  rows+=("$(python3 - "$method" "$out/$method.runs.jsonl" "$verify" "$psnr" <<'PY'
import json, statistics, sys
method, runs, verify, psnr = sys.argv[1:5]
rs = [json.loads(l) for l in open(runs)]
r = rs[0]["report"]
print(json.dumps({"simplifier": method, "runs": len(rs), "input_tets": r["input_tets"],
                  "wall_median": statistics.median(x["wall"] for x in rs), "user_median": statistics.median(x["user"] for x in rs),
                  "tets_per_second_wall": r["input_tets"] / statistics.median(x["wall"] for x in rs),
                  "tets_per_second_cpu": r["input_tets"] / statistics.median(x["user"] for x in rs),
                  "peak_rss_mb": max(x["peak_rss_mb"] for x in rs), "verify_ok": verify == "true",
                  "levels": [l["tets"] for l in r["levels"]], "segments": r["segments"], "store_bytes": r["store_bytes"],
                  "coarsest_psnr_db_vs_full": float(psnr.split()[0])}))
PY
)")
  echo "${rows[-1]}"
done
python3 - "$name" "${rows[@]}" <<'PY'
import json, os, sys, datetime
name, rows = sys.argv[1], [json.loads(r) for r in sys.argv[2:]]
path = "bench/results/preprocess_sample.json"
meshes = []
if os.path.exists(path):  # one entry per mesh; other meshes' entries from earlier runs stay
    old = json.load(open(path))
    meshes = old.get("meshes", [old] if "mesh" in old else [])
machine = os.environ.get("BENCH_MACHINE", "2 cores shared with other builds and benchmarks: wall times inflated; user CPU seconds steadier")
for r in rows:
    r["machine"] = machine
# rows of methods not run this time (METHODS) stay in the mesh's entry
earlier = [m for m in meshes if m["mesh"] == name]
done = {r["simplifier"] for r in rows}
kept = [dict(r, machine=r.get("machine", e.get("machine"))) for e in earlier for r in e["rows"] if r["simplifier"] not in done]
meshes = [m for m in meshes if m["mesh"] != name]
meshes.append({"date": datetime.date.today().isoformat(), "mesh": name, "rows": kept + rows})
json.dump({"note": "preprocess --threads 2, default options; coarsest level: render --budget 1 at 512x512 against the full-resolution mesh's render, PSNR by bench/psnr.py",
           "meshes": meshes}, open(path, "w"), indent=2)
PY
