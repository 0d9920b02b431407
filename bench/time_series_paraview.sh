#!/usr/bin/env bash
# A transient case against ParaView 5.11 (bench/time_series_paraview.py): OpenFOAM's
# lid-driven cavity run here by icoFoam (bench/openfoam_cavity.sh: blockMesh 20×20×6
# hexahedra, deltaT 0.005 to 0.05, 10 steps written in binary after the 0 folder) and the same
# cavity turned into its polyhedral dual (polyDualMesh 60) and run the same way, each
# preprocessed with `--all-steps` into one store of 11 steps (the 0 folder and 10 times). For
# every time ParaView's OpenFOAM reader offers (it skips the 0 folder), the store's step at
# that time, cut at full resolution, against the volume-weighted mean formed from ParaView's
# cell arrays at that time, points matched by coordinates. Writes OUT (default
# bench/results/time_series_paraview.json).
#   bench/time_series_paraview.sh [OUT]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-bench/results/time_series_paraview.json}
work=bench/out/time_series
mkdir -p "$work" bench/results
[[ -d $work/foam/cavity/0.05 && -d $work/foam/dual/0.05 ]] || bench/openfoam_cavity.sh "$work/foam"
binary=$PWD/build/release/apps/tetrascope
rows=()
for c in cavity dual; do
  store=$work/$c.store
  rm -rf "$store"
  start=$(date +%s.%N)
  "$binary" preprocess "$work/foam/$c" --all-steps -o "$store" --progress none > "$work/$c.preprocess.log"
  seconds=$(echo "$(date +%s.%N) - $start" | bc)
  mkdir -p "$work/$c.cuts"
  check=$(pvpython bench/time_series_paraview.py "$work/foam/$c/$c.foam" "$store" "$work/$c.cuts" "$binary" 2> "$work/$c.check.log" | tail -1)
  rows+=("$(/usr/bin/python3 -c 'import json,sys; d=json.loads(sys.argv[1]); d["preprocess_seconds"]=float(sys.argv[2]); d["preprocess"]=open(sys.argv[3]).read().strip(); print(json.dumps(d))' "$check" "$seconds" "$work/$c.preprocess.log")")
done
foam_version=$(dpkg-query -W -f '${Version}' openfoam 2>/dev/null || echo unknown)
paraview_version=$(pvpython -c 'from paraview import servermanager as s; print(s.vtkSMProxyManager.GetVersionMajor(), s.vtkSMProxyManager.GetVersionMinor(), s.vtkSMProxyManager.GetVersionPatch())' 2>/dev/null | tr ' ' '.')
/usr/bin/python3 - "$out" "$foam_version" "$paraview_version" "${rows[@]}" <<'PY'
import json, sys
out, foam, paraview, *rows = sys.argv[1:]
cases = [json.loads(r) for r in rows]
result = {
    "benchmark": "every step of a transient OpenFOAM case, preprocessed as one time series, against ParaView's OpenFOAM reader at the same time",
    "provenance": {
        "cases": "bench/openfoam_cavity.sh: the lid-driven cavity (blockMesh 20x20x6 hexahedra, 0.1 x 0.1 x 0.03 m, nu 0.01, lid 1 m/s) run by icoFoam from t = 0 to 0.05 in steps of 0.005, every step written (binary); dual: the same cavity through polyDualMesh 60 (3087 cells: 2595 hexahedra, 492 general polyhedra decomposed about their centres) run the same way",
        "openfoam": "Debian openfoam " + foam,
        "paraview": paraview,
    },
    "check": "per step and array, max |tetrascope - ParaView volume-weighted mean| / max |ParaView| over the points matched by coordinates (the polyhedra's decomposition points have no ParaView counterpart); goal: within 1e-6",
    "cases": cases,
    "worst_max_relative_difference": max(c["worst_max_relative_difference"] for c in cases),
    "steps_compared": sum(len(c["steps"]) for c in cases),
}
json.dump(result, open(out, "w"), indent=2)
print(json.dumps({"worst_max_relative_difference": result["worst_max_relative_difference"], "steps_compared": result["steps_compared"]}))
PY
