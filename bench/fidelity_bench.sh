#!/usr/bin/env bash
# The best picture per tet (multi-triangulation fidelity): for each case (mesh, camera, transfer
# function or isosurface), the image of the store's cut at budgets of 5/10/25/50% of the input
# and of the whole mesh decimated to the same number of tets by `tetrascope simplify`, each
# compared with the image of the full mesh (PSNR, dB). Volume cases use the exact CPU integrator
# (`render --reference`), so renderer errors stay out, and are compared twice: as 8-bit PNGs
# (cut_db, decimated_db) and as its unrounded colours (cut_db_float, decimated_db_float: above
# about 50 dB the rounding decides the 8-bit figure); isosurface cases use the GL renderer
# (the same renderer on both sides). Every render also draws the GL renderer's image (the
# default volume method), so each row carries the GL figures as well (cut_db_gl,
# decimated_db_gl: GL against GL, 8 bits; the goals ask for both once GL agrees with the
# integrator). Also the coarsest level against a decimation of its size. Where the cut stops
# short of its budget (its refinement steps too large to fit), the row also holds the
# decimation to the whole budget (decimated_at_budget), the comparison the goals are stated in.
# Writes bench/results/fidelity.json.
#   bench/fidelity_bench.sh [CASE...]      (default: every case whose mesh is present)
# Env: FIDELITY_SIZE (default 256x192), FIDELITY_BUDGETS (default "5 10 25 50": percent of the
#      input; "L1": a budget of level 1's tets, a cut the size of that level: the level whole
#      where the view shows the whole mesh; "T350000": a budget of 350,000 tets),
#      PREPROCESS_ARGS (extra options for `tetrascope preprocess`, to compare builds),
#      FIDELITY_TAG (a label stored with the rows, e.g. "before" or "after"; the store is built
#      once per tag and options), TETRASCOPE (a tetrascope binary to use instead of building one),
#      BLADE_1M, BLADE_5M (the blades of make-large.sh, default /work/bigdata/blade-1m.vtk, blade-5m.vtk).
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ -n "${TETRASCOPE:-}" ]]; then
  bin=$TETRASCOPE
else
  cmake --build --preset release -j "$(nproc)" --target tetrascope > /dev/null
  bin=build/release/apps/tetrascope
fi
out=bench/out/fidelity
mkdir -p "$out" bench/results
size=${FIDELITY_SIZE:-256x192}
budgets=${FIDELITY_BUDGETS:-"5 10 25 50"}
tag=${FIDELITY_TAG:-current}
py=/usr/bin/python3
data=../shared/data
blade1m=${BLADE_1M:-/work/bigdata/blade-1m.vtk}
blade5m=${BLADE_5M:-/work/bigdata/blade-5m.vtk}
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
git diff --quiet HEAD -- lod storage apps 2>/dev/null || commit="$commit+changes"
[[ -n "${TETRASCOPE:-}" ]] && commit="given binary $TETRASCOPE"

# name | mesh | camera | mode | unit distance | transfer function (JSON) or isovalue
cases=(
  "onera-wing-broad|$data/onera_m6_potential.vtk|eye=2.2,2.4,1.8,target=0.6,0.7,0,up=0,1,0,fov=40|dvr|0.05|{\"attribute\":\"pressure_coefficient\",\"range\":[-0.72,0.75],\"colormap\":\"viridis\",\"opacity\":[[-0.72,0.9],[-0.25,0.5],[-0.1,0],[0.1,0],[0.3,0.5],[0.75,0.9]]}"
  "onera-wing-narrow|$data/onera_m6_potential.vtk|eye=2.2,2.4,1.8,target=0.6,0.7,0,up=0,1,0,fov=40|dvr|0.05|{\"attribute\":\"pressure_coefficient\",\"range\":[-0.72,0.75],\"colormap\":\"viridis\",\"opacity\":[[-0.72,0.9],[-0.4,0.6],[-0.3,0],[0.75,0]]}"
  "onera-wing-closeup|$data/onera_m6_potential.vtk|eye=1.3,1.5,0.9,target=0.6,0.7,0,up=0,1,0,fov=40|dvr|0.05|{\"attribute\":\"pressure_coefficient\",\"range\":[-0.72,0.75],\"colormap\":\"viridis\",\"opacity\":[[-0.72,0.9],[-0.25,0.5],[-0.1,0],[0.1,0],[0.3,0.5],[0.75,0.9]]}"
  "onera-wing-iso|$data/onera_m6_potential.vtk|eye=2.2,2.4,1.8,target=0.6,0.7,0,up=0,1,0,fov=40|iso|0|pressure_coefficient=-0.2"
  "oxygen-post-outside|$data/nasa_oxygen_post.vtk|azimuth=30,elevation=20|dvr|0|{\"attribute\":\"VelocityMagnitude\",\"colormap\":\"viridis\",\"opacity\":[[0,0],[1.39,0.4]]}"
  "oxygen-post-inside|$data/nasa_oxygen_post.vtk|eye=0,-6,2.4,target=0,6,2.4,up=0,0,1,fov=60|dvr|0|{\"attribute\":\"VelocityMagnitude\",\"colormap\":\"viridis\",\"opacity\":[[0,0],[0.5,0],[1.39,0.6]]}"
  "bracket-outside|$data/fea_bracket.vtk|azimuth=30,elevation=20|dvr|0|{\"attribute\":\"von_mises_stress_psi\",\"colormap\":\"viridis\",\"opacity\":[[0,0],[21,0.5]]}"
  "bracket-inside|$data/fea_bracket.vtk|eye=0,-1.2,1.6,target=0,2,1.6,up=0,0,1,fov=70|dvr|0|{\"attribute\":\"von_mises_stress_psi\",\"colormap\":\"viridis\",\"opacity\":[[0,0],[4,0],[21,0.6]]}"
  "blade1m-outside|$blade1m|azimuth=30,elevation=20|dvr|0|"
  "blade1m-inside|$blade1m|azimuth=30,elevation=20,distance=0.25|dvr|0|"
  "blade5m-outside|$blade5m|azimuth=30,elevation=20|dvr|0|"
  "blade5m-inside|$blade5m|azimuth=30,elevation=20,distance=0.25|dvr|0|"
)

psnr() { "$py" bench/psnr.py "$1" "$2"; }
tets_of() { "$py" -c 'import json,sys; print(json.loads(sys.stdin.read().strip().splitlines()[-1])["tets"])'; }

# decimate TETS LABEL: the case's mesh decimated to TETS tets and rendered (cached by TETS); sets its tets and PSNRs (8 bits, float, GL)
decimate() {
  local dec="$out/$base.dec$1.vtk"
  [[ -s "$dec" ]] || "$bin" simplify "$mesh" -o "$dec" --method qem --tets "$1" > /dev/null
  d_tets=$("$bin" info --json "$dec" | "$py" -c 'import json,sys; print(json.load(sys.stdin)["tetrahedra"])')
  image "$dec" "$out/$name.dec$2" > /dev/null
  d_db=$(psnr "$full" "$(shown "$out/$name.dec$2")") d_float=null
  [[ -n "$full_exact" ]] && d_float=$(psnr "$full_exact" "$(exact "$out/$name.dec$2")")
  d_gl=$(psnr "$out/$name.full.png" "$out/$name.dec$2.png")
}
rows=()
for spec in "${cases[@]}"; do
  IFS='|' read -r name mesh camera mode unit tf <<< "$spec"
  if (($# > 0)) && [[ " $* " != *" $name "* ]]; then continue; fi
  [[ -s "$mesh" ]] || { echo "skip $name: no $mesh"; continue; }
  base=$(basename "${mesh%.vtk}")
  opts=$(echo "${PREPROCESS_ARGS:-}" | tr -c 'A-Za-z0-9.\n' '_')
  store="$out/$base-$tag${opts:+-$opts}.store"
  [[ -d "$store" ]] || "$bin" preprocess "$mesh" -o "$store" --progress none ${PREPROCESS_ARGS:-} > /dev/null
  input_tets=$("$bin" info --json "$mesh" | "$py" -c 'import json,sys; print(json.load(sys.stdin)["tetrahedra"])')
  if [[ -z "$tf" ]]; then  # the first attribute, opacity 0 to 0.3 over its range
    tf=$("$bin" info --json "$mesh" | "$py" -c 'import json,sys; a=json.load(sys.stdin)["attributes"][0]; print(json.dumps({"attribute":a["name"],"colormap":"viridis","opacity":[[a["min"],0],[a["max"],0.3]]}))')
  fi
  args=(--camera "$camera" --size "$size")
  if [[ "$mode" == iso ]]; then
    args+=(--mode iso --attribute "${tf%%=*}" --iso "${tf#*=}")
    image() { "$bin" render "$1" -o "$2.png" "${args[@]}" "${@:3}" --json; }
    shown() { echo "$1.png"; }
    exact() { echo ""; }  # the GL renderer writes 8-bit images only
  else
    echo "$tf" > "$out/$name.tf.json"
    args+=(--tf "$out/$name.tf.json")
    [[ "$unit" != 0 ]] && args+=(--unit-distance "$unit")
    image() { "$bin" render "$1" -o "$2.png" "${args[@]}" "${@:3}" --reference --json; }
    shown() { echo "$1.reference.png"; }
    exact() { echo "$1.reference.pfm"; }  # the integrator's colours before 8-bit rounding
  fi
  image "$mesh" "$out/$name.full" > /dev/null
  full=$(shown "$out/$name.full")
  full_exact=$(exact "$out/$name.full")  # empty for the GL renderer's cases
  # the tets of every level, finest first; the last is the coarsest
  read -r -a level_tets <<< "$("$bin" info --json "$store" | "$py" -c 'import json,sys; print(*(l["tets"] for l in json.load(sys.stdin)["multiresolution"]["levels"]))')"
  coarsest=${level_tets[-1]}
  # which store the rows came from: its DAG and segments hashed, so rows can be checked against a rebuild
  store_id=$(cat "$store/dag.bin" "$store/segments.bin" | sha256sum | cut -c1-16)
  for pct in coarsest $budgets; do
    budget=$coarsest
    if [[ "$pct" =~ ^L([0-9]+)$ ]]; then  # a whole level: the budget of its tets
      budget=${level_tets[${BASH_REMATCH[1]}]}
    elif [[ "$pct" =~ ^T([0-9]+)$ ]]; then  # a budget of so many tets
      budget=$((10#${BASH_REMATCH[1]}))
    elif [[ "$pct" != coarsest ]]; then
      budget=$((input_tets * pct / 100))
    fi
    cut_json=$(image "$store" "$out/$name.cut$pct" --budget "$budget" | tail -1)
    tets=$(tets_of <<< "$cut_json")
    est=$("$py" -c 'import json,sys; print(json.loads(sys.stdin.read()).get("cut_estimated_error", "null"))' <<< "$cut_json")
    cut_db=$(psnr "$full" "$(shown "$out/$name.cut$pct")")
    cut_float=null dec_float=null
    [[ -n "$full_exact" ]] && cut_float=$(psnr "$full_exact" "$(exact "$out/$name.cut$pct")")
    cut_gl=$(psnr "$out/$name.full.png" "$out/$name.cut$pct.png")
    decimate "$tets" "$pct"
    dec_tets=$d_tets dec_db=$d_db dec_float=$d_float dec_gl=$d_gl
    # The goals compare at the budget asked for: where the cut stops short of it
    # (refinement steps too large to fit), also the decimation to the whole budget. null where
    # the cut holds the budget (within 1%: the row's decimation) or cannot go down to it.
    at_budget=null
    if [[ "$pct" != coarsest ]] && ((tets < budget * 99 / 100)); then
      decimate "$budget" "$pct.budget"
      at_budget="{\"tets\":$d_tets,\"db\":$d_db,\"db_float\":$d_float,\"db_gl\":$d_gl}"
    fi
    row="{\"case\":\"$name\",\"tag\":\"$tag\",\"budget\":\"$pct\",\"input_tets\":$input_tets,\"cut_tets\":$tets,\"cut_db\":$cut_db,\"cut_estimated_error\":$est,\"decimated_tets\":$dec_tets,\"decimated_db\":$dec_db,\"cut_db_float\":$cut_float,\"decimated_db_float\":$dec_float,\"cut_db_gl\":$cut_gl,\"decimated_db_gl\":$dec_gl,\"budget_tets\":$budget,\"decimated_at_budget\":$at_budget,\"store\":\"$store_id\",\"coarsest_tets\":$coarsest,\"commit\":\"$commit\"}"
    echo "$row"
    rows+=("$row")
  done
done
"$py" - "$size" "${rows[@]}" <<'PY'
import datetime, json, os, sys
path = "bench/results/fidelity.json"
old = json.load(open(path)) if os.path.exists(path) else {"runs": []}
rows = [json.loads(r) for r in sys.argv[2:]]
keys = {(r["case"], r["tag"], r["budget"]) for r in rows}
kept = [r for r in old.get("runs", []) if (r["case"], r["tag"], r["budget"]) not in keys]
old.update({"date": datetime.date.today().isoformat(), "size": sys.argv[1],
            "method": "PSNR against the full mesh; volume cases by the exact CPU integrator (render --reference), isosurface cases by the GL renderer; every case also GL against GL (cut_db_gl, decimated_db_gl); decimation by tetrascope simplify --tets (the cut's tet count)",
            "runs": kept + rows})  # other keys (tags, notes) are kept
json.dump(old, open(path, "w"), indent=1)
PY
