#!/usr/bin/env bash
# Cell data against ParaView 5.11 (bench/cell_data_paraview.py): files with cell data written
# by ParaView's own writers (disk_out_ref and nasa_bluntfin through Point Data to Cell Data, as
# VTU zlib, VTK legacy binary and Exodus II; a hexahedral wavelet) and OpenFOAM cases run here
# (bench/openfoam_cavity.sh: the cavity's hexahedra and its polyhedral dual), read by
# tetrascope and by ParaView.
# For each file: tetrascope's vertex values against the volume-weighted mean formed in numpy
# from ParaView's cell arrays, cell volumes and connectivity (the conversion's check), and
# against ParaView's Cell Data to Point Data (the plain mean: how far the two conventions
# differ); and read times: tetrascope's reader (`info --json` read_seconds, cell data
# conversion included) against ParaView's reader update (one run, inside the check), and
# whole processes, `tetrascope info FILE` against `pvpython` opening and updating the same
# file and `tetrascope info` of the point-data original, medians of RUNS (default 3)
# alternated. Writes OUT (default bench/results/cell_data_paraview.json).
#   bench/cell_data_paraview.sh [RUNS] [OUT]
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-3}
out=${2:-bench/results/cell_data_paraview.json}
shared=../shared/data
if [[ ! -d $shared ]]; then
  echo "cell_data_paraview: ../shared/data is absent; nothing to measure" >&2
  exit 0
fi
scripts/install-deps --bench > /dev/null
cmake --preset release > /dev/null
cmake --build --preset release -j "$(nproc)" --target tetrascope > /dev/null
work=bench/out/cell_data
mkdir -p "$work" bench/results
pvpython bench/cell_data_paraview.py make "$work" "$shared" 2> "$work/make.log"
bench/openfoam_cavity.sh "$work"
load_before=$(cut -d' ' -f1-3 /proc/loadavg)
now() { date +%s.%N; }
rows=()
for f in disk_out_ref_cells.vtu disk_out_ref_cells.vtk disk_out_ref_cells.exo nasa_bluntfin_cells.vtu nasa_bluntfin_cells.vtk nasa_bluntfin_cells.exo wavelet_hex_cells.vtu cavity/cavity.foam dual/dual.foam cavity_large/cavity_large.foam dual_large/dual_large.foam; do
  path=$work/$f
  ours=$work/$(basename "${f%.*}")_${f##*.}_ours.vtk
  build/release/apps/tetrascope simplify "$path" -o "$ours" --ratio 1 --json > /dev/null
  check=$(pvpython bench/cell_data_paraview.py check "$path" "$ours" 2> "$work/check.log" | tail -1)
  original=$shared/${f%%_cells*}.vtk
  t_ours=() t_pv=() t_points=() t_read=()
  for r in $(seq "$runs"); do
    t_read+=("$(build/release/apps/tetrascope info --json "$path" | python3 -c 'import json,sys; print(json.load(sys.stdin)["read_seconds"])')")
    a=$(now); build/release/apps/tetrascope info "$path" > /dev/null; b=$(now); t_ours+=("$(echo "$b - $a" | bc)")
    a=$(now); pvpython -c "from paraview.simple import OpenDataFile; OpenDataFile('$path').UpdatePipeline()" > /dev/null 2>&1; b=$(now); t_pv+=("$(echo "$b - $a" | bc)")
    if [[ -f $original ]]; then a=$(now); build/release/apps/tetrascope info "$original" > /dev/null; b=$(now); t_points+=("$(echo "$b - $a" | bc)"); fi
  done
  rows+=("$(python3 - "$check" "${t_ours[*]}" "${t_pv[*]}" "${t_points[*]:-}" "$(stat -c %s "$path")" "${t_read[*]}" <<'EOF'
import json, statistics, sys
row = json.loads(sys.argv[1])
med = lambda s: statistics.median(float(x) for x in s.split()) if s.strip() else None
row["file_bytes"] = int(sys.argv[5])
row["read_seconds"] = {"tetrascope_info": med(sys.argv[2]), "paraview_open_update": med(sys.argv[3]),
                       "tetrascope_info_of_point_data_original": med(sys.argv[4])}
row["read_seconds"]["tetrascope_reader"] = med(sys.argv[6])
row["read_seconds"]["paraview_reader"] = row.pop("paraview_reader_seconds")
row["tetrascope_over_paraview_speed"] = row["read_seconds"]["paraview_open_update"] / row["read_seconds"]["tetrascope_info"]
row["reader_speed_over_paraview"] = row["read_seconds"]["paraview_reader"] / row["read_seconds"]["tetrascope_reader"]
print(json.dumps(row))
EOF
)")
done
python3 - "$out" "$runs" "$load_before" "$(cut -d' ' -f1-3 /proc/loadavg)" "${rows[@]}" <<'EOF'
import json, sys
out, runs, before, after = sys.argv[1:5]
rows = [json.loads(r) for r in sys.argv[5:]]
json.dump({"what": "cell data read by tetrascope (volume-weighted mean at the vertices) against ParaView 5.11 on files ParaView wrote",
           "runs": int(runs), "load_average_before": before, "load_average_after": after, "files": rows}, open(out, "w"), indent=1)
worst = max(a.get("max_relative_difference", float("inf")) for r in rows for a in r["arrays"])
print(f"{out}: {len(rows)} files, largest relative difference from the numpy mean {worst:.2e}")
EOF
