#!/usr/bin/env bash
# The cost of the binary segment hierarchy (§6.2) against the multi-triangulation (§6.3) on the
# same mesh, the same run: preprocess wall time and peak RSS (/usr/bin/time), store bytes per
# input tet (segments.bin + dag.bin), levels, segments, dependencies, and whether the store
# passes `verify`. Both with --vertices off (the vertex hierarchy is the same for either
# model) and the same --memory-mb. Appends to bench/results/binary_hierarchy.json ("build").
#   bench/binary_build.sh MESH...
# Env: TETRASCOPE (binary, default build/release/apps/tetrascope), MEMORY_MB (default 2048),
#      REPEATS (default 1: the builds take minutes on the larger meshes)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${TETRASCOPE:-build/release/apps/tetrascope}
out=bench/out/binary
mkdir -p "$out" bench/results
memory=${MEMORY_MB:-2048}
repeats=${REPEATS:-1}
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
git diff --quiet HEAD -- lod storage apps 2>/dev/null || commit="$commit+changes"
rows=()
for mesh in "$@"; do
  name=$(basename "${mesh%.*}")
  for model in mt binary; do
    secs=() rss=()
    for ((r = 0; r < repeats; ++r)); do
      store="$out/$name-$model.store"
      log=$(mktemp)
      /usr/bin/time -f "%M %e" -o "$log" "$bin" preprocess "$mesh" -o "$store" --model "$model" --vertices off --memory-mb "$memory" --force --progress none --json > "$log.json"
      read -r kb s < "$log"
      secs+=("$s") rss+=("$kb")
    done
    ok=$("$bin" verify "$store" --progress none --json | /usr/bin/python3 -c 'import json,sys; print(str(json.load(sys.stdin)["ok"]).lower())')
    row=$(/usr/bin/python3 - "$log.json" "$store" "$name" "$model" "$ok" "$commit" "$memory" "${secs[*]}" "${rss[*]}" <<'PY'
import json, os, statistics, sys
rep = json.load(open(sys.argv[1]))
store, name, model, ok, commit, memory = sys.argv[2:8]
secs = [float(x) for x in sys.argv[8].split()]
rss = [int(x) for x in sys.argv[9].split()]
size = sum(os.path.getsize(os.path.join(store, f)) for f in ("segments.bin", "dag.bin"))
print(json.dumps({"mesh": name, "model": model, "input_tets": rep["input_tets"], "seconds": statistics.median(secs), "runs": len(secs),
                  "peak_rss_mb": round(statistics.median(rss) / 1024, 1), "bytes_per_tet": round(size / rep["input_tets"], 1),
                  "levels": len(rep["levels"]), "segments": rep["segments"], "patches": rep["patches"], "dependencies": rep.get("dependencies", 0),
                  "stored_tets_over_input": round(sum(l["tets"] for l in rep["levels"]) / rep["input_tets"], 3),
                  "coarsest_tets": rep["levels"][-1]["tets"], "segment_tets": rep["segment_tets"], "level_ratio": rep["level_ratio"],
                  "memory_mb": int(memory), "verify_ok": ok == "true", "commit": commit}))
PY
)
    echo "$row"
    rows+=("$row")
    rm -f "$log" "$log.json"
  done
done
/usr/bin/python3 - "${rows[@]}" <<'PY'
import datetime, json, os, sys
path = "bench/results/binary_hierarchy.json"
old = json.load(open(path)) if os.path.exists(path) else {}
rows = [json.loads(r) for r in sys.argv[1:]]
keys = {(r["mesh"], r["model"]) for r in rows}
old["build"] = [r for r in old.get("build", []) if (r["mesh"], r["model"]) not in keys] + rows
old["build_method"] = "bench/binary_build.sh: tetrascope preprocess --model mt|binary --vertices off, wall time and peak RSS by /usr/bin/time (median of `runs`), store bytes = segments.bin + dag.bin over the input's tets; 2-core machine shared with other builds"
old["date"] = datetime.date.today().isoformat()
json.dump(old, open(path, "w"), indent=1)
PY
