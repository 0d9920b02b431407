#!/usr/bin/env bash
# What segment variants cost (`preprocess --variants K`): preprocess time, peak RSS
# and store bytes without and with them, whole-process, the two builds alternated in each
# round; medians over RUNS rounds (default 3). Writes bench/results/variants_cost.json.
#   bench/variants_cost.sh [MESH...]   (default: ONERA M6, the oxygen post, the bracket, the 1M blade)
# Environment: RUNS, VARIANTS (default 3), TETRASCOPE (a built binary; default build/release),
# BEFORE (another binary, e.g. an older commit's: its --variants K build joins each round, and
# the summary says whether its variants.bin is byte-identical to this one's).
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ -n "${TETRASCOPE:-}" ]]; then
  bin=$TETRASCOPE
else
  cmake --build --preset release -j "$(nproc)" --target tetrascope > /dev/null
  bin=build/release/apps/tetrascope
fi
runs=${RUNS:-3}
variants=${VARIANTS:-3}
py=/usr/bin/python3
out=bench/out/variants_cost
mkdir -p "$out" bench/results
meshes=("$@")
((${#meshes[@]} > 0)) || meshes=(../shared/data/onera_m6_potential.vtk ../shared/data/nasa_oxygen_post.vtk ../shared/data/fea_bracket.vtk "${BLADE_1M:-/work/bigdata/blade-1m.vtk}")
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
git diff --quiet HEAD -- lod storage apps 2>/dev/null || commit="$commit+changes"
rows=()
for mesh in "${meshes[@]}"; do
  [[ -s "$mesh" ]] || { echo "skip $mesh: missing" >&2; continue; }
  name=$(basename "${mesh%.*}")
  builds=("0 $bin" "$variants $bin")
  [[ -n "${BEFORE:-}" ]] && builds=("0 $bin" "$variants ${BEFORE}" "$variants $bin")
  for ((r = 0; r < runs; ++r)); do
    for build in "${builds[@]}"; do
      read -r k with <<< "$build"
      before=0
      [[ "$with" != "$bin" ]] && before=1
      store="$out/$name-v$k-b$before.store"
      rm -rf "$store"
      /usr/bin/time -f '%e %M' -o "$out/time" "$with" preprocess "$mesh" -o "$store" --variants "$k" --progress none --json > "$out/report.json"
      read -r seconds rss_kb < "$out/time"
      sha=$([[ -f "$store/variants.bin" ]] && sha256sum "$store/variants.bin" | cut -c1-16 || echo none)
      row=$("$py" - "$out/report.json" "$name" "$k" "$seconds" "$rss_kb" "$before" "$sha" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
print(json.dumps({"mesh": sys.argv[2], "variants": int(sys.argv[3]), "before": sys.argv[6] == "1", "seconds": float(sys.argv[4]), "peak_rss_mb": int(sys.argv[5]) / 1024,
                  "input_tets": j["input_tets"], "store_bytes": j["store_bytes"], "variants_bytes": j.get("variants_bytes", 0),
                  "variant_tets": j.get("variant_tets", 0), "variants_sha": sys.argv[7]}))
PY
)
      echo "$row"
      rows+=("$row")
    done
  done
done
"$py" - "$runs" "$commit" "${rows[@]}" <<'PY'
import datetime, json, os, statistics, sys
runs, commit, rows = int(sys.argv[1]), sys.argv[2], [json.loads(r) for r in sys.argv[3:]]
summary = []
for mesh in dict.fromkeys(r["mesh"] for r in rows):
    by = {k: [r for r in rows if r["mesh"] == mesh and r["variants"] == k and not r.get("before")] for k in sorted({r["variants"] for r in rows if r["mesh"] == mesh})}
    earlier = [r for r in rows if r["mesh"] == mesh and r.get("before")]
    base, with_ = by[0], by[max(by)]
    med = lambda rs, key: statistics.median(r[key] for r in rs)
    summary.append({"mesh": mesh, "input_tets": base[0]["input_tets"], "variants": max(by), "runs": len(base),
                     "seconds": [med(base, "seconds"), med(with_, "seconds")], "seconds_ratio": med(with_, "seconds") / med(base, "seconds"),
                     "peak_rss_mb": [med(base, "peak_rss_mb"), med(with_, "peak_rss_mb")],
                     "store_bytes": [base[0]["store_bytes"], with_[0]["store_bytes"]], "store_ratio": with_[0]["store_bytes"] / base[0]["store_bytes"],
                     "variants_bytes_per_input_tet": with_[0]["variants_bytes"] / base[0]["input_tets"], "variant_tets": with_[0]["variant_tets"]})
    if earlier:
        summary[-1].update({"seconds_before": med(earlier, "seconds"), "seconds_ratio_before": med(earlier, "seconds") / med(base, "seconds"),
                            "peak_rss_mb_before": med(earlier, "peak_rss_mb"),
                            "same_variants_as_before": {r["variants_sha"] for r in earlier} == {r["variants_sha"] for r in with_}})
    print(json.dumps(summary[-1]))
json.dump({"date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"), "commit": commit,
           "method": "tetrascope preprocess --variants 0 and K alternated (and K with the BEFORE binary where given), whole process under /usr/bin/time; medians over the runs; shared 2-core machine",
           "before": os.environ.get("BEFORE_LABEL", os.environ.get("BEFORE", "")),
           "summary": summary, "rows": rows}, open("bench/results/variants_cost.json", "w"), indent=1)
PY
