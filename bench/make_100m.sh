#!/usr/bin/env bash
# A 100M+-tet mesh without gmsh (gmsh needs ~0.5 GB a million tets): the ~13.6M-tet
# turbine blade refined 1:8 by bench/refine_tets, the analytic field evaluated at every vertex.
# Measures wall time and peak RSS (/usr/bin/time -v), reads the result back with
# `tetrascope info --json` and writes bench/results/make_100m.json.
#
#   bench/make_100m.sh [IN] [OUT.vtk]
#
# Defaults: /work/bigdata/blade-13m.vtk -> /work/bigdata/blade-100m.vtk. A missing IN is made
# by ../shared/data/make/make-large.sh 13500000 IN analytic (gmsh, ~7 GB, a few minutes).
# OUT takes about 3.1 GB of disk for 108M tets. RESULT=path overrides the results file.
set -euo pipefail
in="$(realpath -m "${1:-/work/bigdata/blade-13m.vtk}")"
out="$(realpath -m "${2:-/work/bigdata/blade-100m.vtk}")"
cd "$(dirname "$0")/.."
result="${RESULT:-bench/results/make_100m.json}"
cmake --preset release > /dev/null
cmake --build --preset release -j 2 --target refine_tets tetrascope > /dev/null
if [[ ! -f "$in" ]]; then
  echo "generating $in with make-large.sh 13500000 (analytic field)"
  bash ../shared/data/make/make-large.sh 13500000 "$in" analytic
fi
mkdir -p "$(dirname "$out")" "$(dirname "$result")"
work="$(mktemp -d)"; trap 'rm -rf "$work"' EXIT

echo "refining $in -> $out"
/usr/bin/time -v -o "$work/time" build/release/bench/refine_tets "$in" "$out" > "$work/report.json"
cat "$work/report.json"
echo "reading it back: tetrascope info --json $out"
/usr/bin/time -v -o "$work/info.time" build/release/apps/tetrascope info --json "$out" > "$work/info.json"
sha="$(sha256sum "$out" | cut -d' ' -f1)"

python3 - "$work" "$in" "$out" "$sha" "$result" <<'PY'
import datetime, json, os, platform, sys
work, src, dst, sha, result = sys.argv[1:6]

def gnu_time(path):
    fields = {}
    for line in open(path):
        key, _, value = line.strip().rpartition(": ")
        fields[key] = value
    wall = fields["Elapsed (wall clock) time (h:mm:ss or m:ss)"].split(":")
    seconds = sum(float(x) * 60 ** i for i, x in enumerate(reversed(wall)))
    return {"wall_seconds": round(seconds, 2), "user_seconds": float(fields["User time (seconds)"]),
            "system_seconds": float(fields["System time (seconds)"]),
            "peak_rss_mb": round(int(fields["Maximum resident set size (kbytes)"]) / 1024, 1)}

report = json.load(open(f"{work}/report.json"))
info = json.load(open(f"{work}/info.json"))
ok = (info["tetrahedra"] == report["output_tets"] and info["vertices"] == report["output_vertices"]
      and info["quality"]["inverted"] == 0 and info["quality"]["degenerate"] == 0)
refine = gnu_time(f"{work}/time")
doc = {
    "date": datetime.date.today().isoformat(),
    "machine": f"{os.cpu_count()} cores, {round(os.sysconf('SC_PAGE_SIZE') * os.sysconf('SC_PHYS_PAGES') / 2**30)} GB, {platform.system()}",
    "method": "bench/make_100m.sh: one run of bench/refine_tets (one thread) under /usr/bin/time -v, input in the page cache; "
              "then `tetrascope info --json` on the output",
    "input": {"file": os.path.basename(src), "bytes": os.path.getsize(src),
              "vertices": report["input_vertices"], "tetrahedra": report["input_tets"]},
    "output": {"file": os.path.basename(dst), "bytes": os.path.getsize(dst), "sha256": sha,
               "vertices": report["output_vertices"], "tetrahedra": report["output_tets"], "edges_of_input": report["edges"]},
    "refine": dict(refine, **{k: report[k] for k in ("read_seconds", "edge_seconds", "write_seconds", "field",
                                                      "volume_in", "volume_out", "children_flipped", "children_flat",
                                                      "analytic_max_abs_difference_at_input_vertices")}),
    "info_check": dict(gnu_time(f"{work}/info.time"), ok=ok, vertices=info["vertices"], tetrahedra=info["tetrahedra"],
                       inverted=info["quality"]["inverted"], degenerate=info["quality"]["degenerate"],
                       attributes=[{"name": a["name"], "min": a["min"], "max": a["max"]} for a in info["attributes"]],
                       read_seconds=info["read_seconds"]),
}
with open(result, "w") as f:
    json.dump(doc, f, indent=2)
    f.write("\n")
print(json.dumps(doc, indent=2))
if not ok:
    sys.exit("tetrascope info disagrees with refine_tets (counts) or found inverted or degenerate tets")
PY
