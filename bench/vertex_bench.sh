#!/bin/sh
# The vertex hierarchy's cost and speed, mesh by mesh: `tetrascope preprocess` with the
# defaults (vertices.bin built) REPEAT times, each beside the same build with --vertices off:
# the median wall time and whole-process CPU seconds (user + system) with and without it (the
# hierarchy is built beside the levels, so its own build time is not what it adds), the
# store's bytes with and without vertices.bin, peak RSS with and without it; then
# bench/vertex_bench on the store (bytes an update,
# splits and collapses a second on one core, front updates on an orbit).
#   bench/vertex_bench.sh [MESH ...]   (REPEAT=3 by default; default meshes: the shared
#   datasets onera_m6_potential, nasa_oxygen_post, fea_bracket, nasa_bluntfin)
# Adds a record to bench/results/vertex_bench.json.
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
data="$root/../shared/data"
bin="$root/build/release/apps/tetrascope"
bench="$root/build/release/bench/vertex_bench"
out="$root/bench/out/vertex_bench"
repeat=${REPEAT:-3}
mkdir -p "$out"
[ $# -gt 0 ] || set -- "$data/onera_m6_potential.vtk" "$data/nasa_oxygen_post.vtk" "$data/fea_bracket.vtk" "$data/nasa_bluntfin.vtk"
rows="$out/rows.jsonl"
: > "$rows"
for mesh in "$@"; do
  [ -f "$mesh" ] || { echo "skip $mesh: not present" >&2; continue; }
  name=$(basename "$mesh" .vtk)
  i=0
  while [ "$i" -lt "$repeat" ]; do
    # with the hierarchy, then the same build without it (--vertices off), alternating: CPU
    # seconds (user + system) of the whole process beside the wall time
    /usr/bin/time -f '%M %U %S' -o "$out/$name.rss" "$bin" preprocess "$mesh" -o "$out/$name.store" --force --progress none --json > "$out/$name.$i.json"
    /usr/bin/time -f '%e %U %S %M' -o "$out/$name.off.time" "$bin" preprocess "$mesh" -o "$out/$name.off.store" --vertices off --force --progress none --json > /dev/null
    read -r rss user sys < "$out/$name.rss"
    read -r off_wall off_user off_sys off_rss < "$out/$name.off.time"
    echo "{\"run\": $i, \"rss_kb\": $rss, \"cpu_seconds\": $(awk "BEGIN{print $user + $sys}"), \"without\": {\"wall_seconds\": $off_wall, \"rss_kb\": $off_rss, \"cpu_seconds\": $(awk "BEGIN{print $off_user + $off_sys}")}, \"report\": $(cat "$out/$name.$i.json")}" > "$out/$name.$i.run.json"
    i=$((i + 1))
  done
  "$bench" "$out/$name.store" > "$out/$name.bench.json"
  python3 - "$out" "$name" "$repeat" "$(cat /proc/loadavg)" >> "$rows" <<'EOF'
import json, statistics, sys
out, name, repeat, load = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
runs = [json.load(open(f"{out}/{name}.{i}.run.json")) for i in range(repeat)]
total = statistics.median(r["report"]["seconds"] for r in runs)
vertices = statistics.median(r["report"]["stage_seconds"]["vertices"] for r in runs)
report = runs[0]["report"]
bench = json.load(open(f"{out}/{name}.bench.json"))
store = report["store_bytes"]
vbytes = report["vertices"].get("bytes", 0)
print(json.dumps({"mesh": name, "input_tets": report["input_tets"], "runs": repeat, "load": load,
                  "preprocess_seconds": total, "vertices_seconds": vertices,
                  "store_bytes": store, "vertices_bytes": vbytes, "size_over_without": store / (store - vbytes) - 1,
                  "cpu_seconds": statistics.median(r["cpu_seconds"] for r in runs), "cpu_seconds_without": statistics.median(r["without"]["cpu_seconds"] for r in runs),
                  "cpu_over_without": statistics.median(r["cpu_seconds"] / r["without"]["cpu_seconds"] for r in runs) - 1,
                  "wall_over_without": statistics.median(r["report"]["seconds"] / r["without"]["wall_seconds"] for r in runs) - 1,
                  "peak_rss_kb": statistics.median(r["rss_kb"] for r in runs), "peak_rss_kb_without": statistics.median(r["without"].get("rss_kb", 0) for r in runs), "hierarchy": bench}))
EOF
done
python3 - "$rows" "$root/bench/results/vertex_bench.json" "$(git -C "$root" rev-parse --short HEAD)" <<'EOF'
import datetime, json, os, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
record = {"date": datetime.date.today().isoformat(), "commit": sys.argv[3], "cores": os.cpu_count(),
          "method": "preprocess defaults, medians of the runs (wall and CPU over --vertices off, alternating runs; vertices_seconds: the hierarchy's own build, beside the levels); vertex_bench one core, medians of 5 passes", "rows": rows}
# each run a record: {"records": [...]}, the oldest first (a file of one bare record is kept as the first)
old = json.load(open(sys.argv[2])) if os.path.exists(sys.argv[2]) else {"records": []}
records = old["records"] if "records" in old else [old]
json.dump({"records": records + [record]}, open(sys.argv[2], "w"), indent=1)
EOF
cat "$root/bench/results/vertex_bench.json"
