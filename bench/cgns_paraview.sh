#!/usr/bin/env bash
# CGNS against ParaView 5.11: disk_out_ref and nasa_bluntfin (shared data) through ParaView's
# Point Data to Cell Data, written by ParaView's CGNSWriter (CGNS 4.2, HDF5: one zone of
# tets, the cell data as a CellCenter solution), and the same with the point data kept beside
# it (a Vertex solution too). Each file is read by tetrascope (written out unchanged by
# `simplify --ratio 1`) and by ParaView's CGNS reader (every array enabled), and checked as
# bench/cell_data_paraview.py checks the other formats: tetrascope's vertex values against
# the volume-weighted mean formed in numpy from ParaView's cell arrays, and against ParaView's
# Cell Data to Point Data. Read times: tetrascope's reader (`info --json` read_seconds) against
# ParaView's reader update (one run, inside the check), and whole processes, `tetrascope info
# FILE` against `pvpython` opening and updating it with every array, medians of RUNS (default
# 3) alternated. Writes OUT (default bench/results/cgns_paraview.json). BUILD (default
# build/release) names the build whose tetrascope is measured; the release preset is built
# when it is the default.
#   bench/cgns_paraview.sh [RUNS] [OUT]
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-3}
out=${2:-bench/results/cgns_paraview.json}
build=${BUILD:-build/release}
shared=../shared/data
if [[ ! -d $shared ]]; then
  echo "cgns_paraview: ../shared/data is absent; nothing to measure" >&2
  exit 0
fi
scripts/install-deps --bench > /dev/null
if [[ $build == build/release ]]; then
  cmake --preset release > /dev/null
  cmake --build --preset release -j "$(nproc)" --target tetrascope > /dev/null
fi
tetrascope=$build/apps/tetrascope
work=bench/out/cgns
mkdir -p "$work" bench/results
pvpython - "$work" "$shared" > "$work/make.log" 2>&1 <<'EOF_PY'
import os, sys
from paraview.simple import CGNSWriter, LegacyVTKReader, PointDatatoCellData
out, shared = sys.argv[1:3]
for name in ("disk_out_ref", "nasa_bluntfin"):
    for keep_points in (0, 1):
        cells = PointDatatoCellData(Input=LegacyVTKReader(FileNames=[os.path.join(shared, name + ".vtk")]))
        cells.ProcessAllArrays = 1
        cells.PassPointData = keep_points
        path = os.path.join(out, name + ("_both" if keep_points else "_cells") + ".cgns")
        CGNSWriter(Input=cells, FileName=path).UpdatePipeline()
EOF_PY
load_before=$(cut -d' ' -f1-3 /proc/loadavg)
now() { date +%s.%N; }
rows=()
for f in disk_out_ref_cells.cgns disk_out_ref_both.cgns nasa_bluntfin_cells.cgns nasa_bluntfin_both.cgns; do
  path=$work/$f
  ours=$work/${f%.*}_ours.vtk
  "$tetrascope" simplify "$path" -o "$ours" --ratio 1 --json > /dev/null
  check=$(pvpython bench/cell_data_paraview.py check "$path" "$ours" 2> "$work/check.log" | tail -1)
  t_ours=() t_pv=() t_read=()
  for r in $(seq "$runs"); do
    t_read+=("$("$tetrascope" info --json "$path" | python3 -c 'import json,sys; print(json.load(sys.stdin)["read_seconds"])')")
    a=$(now); "$tetrascope" info "$path" > /dev/null; b=$(now); t_ours+=("$(echo "$b - $a" | bc)")
    a=$(now)
    pvpython -c "from paraview.simple import OpenDataFile; r = OpenDataFile('$path'); r.UpdatePipelineInformation(); r.CellArrayStatus = r.CellArrayStatus.Available; r.PointArrayStatus = r.PointArrayStatus.Available; r.UpdatePipeline()" > /dev/null 2>&1
    b=$(now); t_pv+=("$(echo "$b - $a" | bc)")
  done
  rows+=("$(python3 - "$check" "${t_ours[*]}" "${t_pv[*]}" "$(stat -c %s "$path")" "${t_read[*]}" <<'EOF_PY'
import json, statistics, sys
row = json.loads(sys.argv[1])
med = lambda s: statistics.median(float(x) for x in s.split())
row["file_bytes"] = int(sys.argv[4])
row["read_seconds"] = {"tetrascope_info": med(sys.argv[2]), "paraview_open_update": med(sys.argv[3]), "tetrascope_reader": med(sys.argv[5]),
                       "paraview_reader": row.pop("paraview_reader_seconds")}
row["tetrascope_over_paraview_speed"] = row["read_seconds"]["paraview_open_update"] / row["read_seconds"]["tetrascope_info"]
row["reader_speed_over_paraview"] = row["read_seconds"]["paraview_reader"] / row["read_seconds"]["tetrascope_reader"]
print(json.dumps(row))
EOF_PY
)")
done
python3 - "$out" "$runs" "$load_before" "$(cut -d' ' -f1-3 /proc/loadavg)" "${rows[@]}" <<'EOF_PY'
import json, sys
out, runs, before, after = sys.argv[1:5]
rows = [json.loads(r) for r in sys.argv[5:]]
json.dump({"what": "CGNS files written by ParaView 5.11's CGNSWriter (CGNS 4.2, HDF5) read by tetrascope (cell data volume-weighted at the vertices) against ParaView's CGNS reader",
           "runs": int(runs), "load_average_before": before, "load_average_after": after, "files": rows}, open(out, "w"), indent=1)
worst = max(a.get("max_relative_difference", float("inf")) for r in rows for a in r["arrays"])
print(f"{out}: {len(rows)} files, largest relative difference from the numpy mean {worst:.2e}")
EOF_PY
