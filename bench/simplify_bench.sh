#!/usr/bin/env bash
# tetrascope simplify next to VTK's vtkUnstructuredGridQuadricDecimation (pvpython, ParaView
# 5.11) on the shared datasets and the ~1M-tet blade, at 10% and 2% of the tets, one scalar
# each (VTK's filter takes a single scalar). Both outputs are judged by `tetrascope error`:
# mean field error (RMS, normalised), max field error, boundary Hausdorff and mean distance.
# Writes bench/results/simplify.json.   usage: bench/simplify_bench.sh [--quick]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps --bench > /dev/null
cmake --preset release > /dev/null
cmake --build --preset release -j "$(nproc)" --target tetrascope > /dev/null
out=bench/out/simplify
mkdir -p "$out" bench/results
data=../shared/data
cases=("$data/disk_out_ref.vtk Temp" "$data/fea_bracket.vtk von_mises_stress_psi" "$data/freefem_leman.vtk potential"
       "$data/nasa_bluntfin.vtk Density" "$data/nasa_combustion_chamber.vtk Density" "$data/nasa_oxygen_post.vtk VelocityMagnitude"
       "$data/onera_m6_potential.vtk pressure_coefficient")
if [[ "${1:-}" != "--quick" ]]; then
  [[ -s bench/out/blade1m.vtk ]] || bash "$data/make/make-large.sh" 1000000 "$(realpath -m bench/out/blade1m.vtk)" analytic > /dev/null
  cases+=("bench/out/blade1m.vtk analytic_f")
fi
rows=()
for c in "${cases[@]}"; do
  read -r mesh scalar <<< "$c"
  name=$(basename "${mesh%.vtk}")
  for ratio in 0.1 0.02; do
    ours="$out/$name.$ratio.ours.vtk"; theirs="$out/$name.$ratio.vtk.vtk"
    o=$(build/release/apps/tetrascope simplify "$mesh" -o "$ours" --ratio "$ratio" --attribute "$scalar" --json)
    v=$(pvpython bench/vtk_decimate.py "$mesh" "$theirs" "$ratio" "$scalar" 2>/dev/null | tail -1)
    eo=$(build/release/apps/tetrascope error "$mesh" "$ours" --json)
    ev=$(build/release/apps/tetrascope error "$mesh" "$theirs" --json)
    rows+=("$(python3 - "$name" "$scalar" "$ratio" "$o" "$v" "$eo" "$ev" <<'PY'
import json, sys
name, scalar, ratio, o, v, eo, ev = sys.argv[1:8]
o, v, eo, ev = map(json.loads, (o, v, eo, ev))
def err(e):
    f = next(x for x in e["fields"] if x["name"] == scalar)
    return {"mean_field_error": f["mean_field_error"], "max_field_error": f["max_field_error"],
            "hausdorff_relative": e["domain_error"]["hausdorff_relative"], "mean_distance_relative": e["domain_error"]["mean_relative"]}
row = {"mesh": name, "scalar": scalar, "ratio": float(ratio), "tets": o["tets_before"],
       "tetrascope": dict(err(eo), tets=o["tets_after"], seconds=o["seconds"], collapses_per_second=o["collapses_per_second"]),
       "vtk": dict(err(ev), tets=v["tets_after"], seconds=v["seconds"],
                   collapses_per_second=(v["tets_before"] - v["tets_after"]) / 6.0 / v["seconds"])}
print(json.dumps(row))
PY
)")
    echo "${rows[-1]}" | cut -c1-150
  done
done
python3 - "${rows[@]}" <<'PY'
import json, sys, datetime
rows = [json.loads(r) for r in sys.argv[1:]]
json.dump({"date": datetime.date.today().isoformat(), "machine": "2 cores, 24 GB, Debian 12",
           "note": "tetrascope: one thread, independent edge collapses (default options) on one scalar; VTK: ParaView 5.11 vtkUnstructuredGridQuadricDecimation, defaults; seconds exclude file I/O for both; VTK's collapses/s estimated as removed tets / 6",
           "rows": rows}, open("bench/results/simplify.json", "w"), indent=2)
print(f"{'mesh':26} {'ratio':>5} {'tets':>8} | {'ours s':>7} {'VTK s':>7} {'speed':>6} | {'Ef ours':>8} {'Ef VTK':>8} | {'max ours':>8} {'max VTK':>8} | {'Hd ours':>8} {'Hd VTK':>8}")
for r in rows:
    o, v = r["tetrascope"], r["vtk"]
    print(f"{r['mesh']:26} {r['ratio']:5} {r['tets']:8} | {o['seconds']:7.2f} {v['seconds']:7.2f} {v['seconds']/o['seconds']:5.2f}x | "
          f"{o['mean_field_error']:8.5f} {v['mean_field_error']:8.5f} | {o['max_field_error']:8.4f} {v['max_field_error']:8.4f} | "
          f"{100*o['hausdorff_relative']:7.3f}% {100*v['hausdorff_relative']:7.3f}%")
PY
