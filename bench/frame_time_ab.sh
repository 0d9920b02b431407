#!/bin/bash
# Two tetrascope binaries' GL frame times on the same meshes, alternated run by run so that
# the machine's load falls on both alike: each run is the median frame of a 4-frame orbit at
# 1024x768 with the default view and transfer function (`render --orbit 4 --json`); per mesh
# the median of ROUNDS runs of each, and their ratio. Writes JSON to stdout.
#
#   bench/frame_time_ab.sh BINARY_A BINARY_B [ROUNDS] [MESH ...]
#   (default meshes: onera_m6_potential nasa_bluntfin disk_out_ref fea_bracket from ../shared/data)
set -eu
a=$1 b=$2 rounds=${3:-3}
shift $(( $# < 3 ? $# : 3 ))
data=$(cd "$(dirname "$0")/../.." && pwd)/shared/data
meshes=("$@")
[ ${#meshes[@]} -eq 0 ] && meshes=("$data/onera_m6_potential.vtk" "$data/nasa_bluntfin.vtk" "$data/disk_out_ref.vtk" "$data/fea_bracket.vtk")
out=$(mktemp -d)
frame() { "$1" render "$2" -o "$out/frame.png" --size 1024x768 --orbit 4 --json | tail -1 | /usr/bin/python3 -c 'import json,sys; print(json.load(sys.stdin)["median_ms"])'; }
{
  for m in "${meshes[@]}"; do
    for r in $(seq "$rounds"); do
      echo "$(basename "$m") a $(frame "$a" "$m")"
      echo "$(basename "$m") b $(frame "$b" "$m")"
    done
  done
} | /usr/bin/python3 -c '
import json, os, statistics, sys
runs = {}
for line in sys.stdin:
    mesh, which, ms = line.split()
    runs.setdefault(mesh, {"a": [], "b": []})[which].append(float(ms))
rows = [{"mesh": m, "a_ms": r["a"], "b_ms": r["b"], "a_median_ms": statistics.median(r["a"]), "b_median_ms": statistics.median(r["b"]),
         "b_over_a": statistics.median(r["b"]) / statistics.median(r["a"])} for m, r in runs.items()]
print(json.dumps({"a": sys.argv[1], "b": sys.argv[2], "rounds": int(sys.argv[3]), "load": os.getloadavg(), "size": "1024x768",
                  "method": "median frame of a 4-frame orbit, default view and transfer function, the two binaries alternated run by run", "rows": rows}, indent=1))
' "$a" "$b" "$rounds"
rm -rf "$out"
