#!/usr/bin/env bash
# Stream lines: `tetrascope streamlines` against ParaView's Stream Tracer (vtkStreamTracer, RK4-5)
# on three shared datasets, 1,000 seeds on a line rake through the flow, forward, same field and
# maximal length. Times: medians of RUNS runs, ours on 1 and 2 threads (VTK's SMP backend here is
# Sequential: one thread), setup (face adjacency + seed grid) included, file reading excluded for
# both. Distances: bench/paraview_streamlines.py. Writes bench/results/streamlines.json.
#   bench/streamlines_bench.sh [RUNS=3]
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-3}
bin=build/release/apps/tetrascope
data=../shared/data
out=bench/out/streamlines
mkdir -p "$out" bench/results
# name  file  field  rake  max_length
cases=(
  "disk_out_ref disk_out_ref.vtk Velocity 0,-5,2,0,5,2,1000 100"
  "nasa_bluntfin nasa_bluntfin.vtk Velocity -2,4,0.2,-2,4,5,1000 40"
  "onera_m6_potential onera_m6_potential.vtk velocity -0.3,0.02,-0.1,-0.3,1.3,0.1,1000 5"
)
rows=()
for c in "${cases[@]}"; do
  read -r name file field rake length <<<"$c"
  for threads in 1 2; do
    : >"$out/$name.t$threads.jsonl"
    for ((r = 0; r < runs; ++r)); do
      "$bin" streamlines "$data/$file" --field "$field" --seeds "line:$rake" --direction forward --max-length "$length" \
        --threads "$threads" -o "$out/$name.vtk" --json | tr -d '\n' >>"$out/$name.t$threads.jsonl"
      echo >>"$out/$name.t$threads.jsonl"
    done
  done
  # accuracy at a tight tolerance (one run, one thread): how much of the distance is our default tolerance
  "$bin" streamlines "$data/$file" --field "$field" --seeds "line:$rake" --direction forward --max-length "$length" \
    --threads 1 --tolerance 1e-6 -o "$out/$name.tight.vtk" --json | tr -d '\n' >"$out/$name.tight.json"
  pv=$(pvpython bench/paraview_streamlines.py "$data/$file" "$field" "$rake" "$length" "default=$out/$name.vtk,tolerance_1e-6=$out/$name.tight.vtk" "$runs" 2>/dev/null | tail -1)
  rows+=("$(python3 - "$name" "$field" "$rake" "$length" "$out/$name.t1.jsonl" "$out/$name.t2.jsonl" "$pv" "$out/$name.tight.json" <<'PY'
import json, statistics, sys
name, field, rake, length, t1, t2, pv, tight = sys.argv[1:]
def load(p): return [json.loads(l) for l in open(p) if l.strip()]
one, two, pv, tight = load(t1), load(t2), json.loads(pv), json.load(open(tight))
d, dt = pv["against"]["default"], pv["against"]["tolerance_1e-6"]
med = lambda rows, k: statistics.median(r[k] for r in rows)
ours1, ours2 = med(one, "seconds"), med(two, "seconds")
print(json.dumps({
  "mesh": name, "field": field, "seeds": "line:" + rake, "max_length": float(length), "tets": one[0]["tets"],
  "tetrascope": {"lines": one[0]["lines"], "points": one[0]["points"], "stops": one[0]["stops"],
                 "seconds_1_thread": ours1, "trace_seconds_1_thread": med(one, "trace_seconds"), "setup_seconds_1_thread": med(one, "setup_seconds"),
                 "seconds_2_threads": ours2, "trace_seconds_2_threads": med(two, "trace_seconds")},
  "paraview": {"seconds": pv["paraview_seconds"], "runs": pv["paraview_runs"], "lines": pv["paraview_lines"], "points": pv["paraview_points"],
               "stops": pv["paraview_stops"]},
  "speedup_1_thread": pv["paraview_seconds"] / ours1, "speedup_2_threads": pv["paraview_seconds"] / ours2,
  "matched_lines": d["matched_lines"],
  "distance_cells_mean": d["distance_cells_mean"], "distance_cells_median_line": d["distance_cells_median_line"],
  "distance_cells_p95_line": d["distance_cells_p95_line"], "distance_cells_max": d["distance_cells_max"],
  "length_ratio_median": d["length_ratio_median"],
  "tolerance_1e-6": {"seconds_1_thread": tight["seconds"], "points": tight["points"], "speedup_1_thread": pv["paraview_seconds"] / tight["seconds"],
                     "distance_cells_mean": dt["distance_cells_mean"], "distance_cells_median_line": dt["distance_cells_median_line"],
                     "distance_cells_p95_line": dt["distance_cells_p95_line"], "distance_cells_max": dt["distance_cells_max"]}}))
PY
)")
  echo "${rows[-1]}" >&2
done
python3 - "$runs" "${rows[@]}" >bench/results/streamlines.json <<'PY'
import datetime, json, os, sys
runs, rows = int(sys.argv[1]), [json.loads(r) for r in sys.argv[2:]]
print(json.dumps({
  "date": datetime.date.today().isoformat(), "machine": f"{os.cpu_count()} cores (shared)",
  "note": ("1,000 seeds on a line rake, forward, same maximal length. tetrascope: Dormand-Prince RK5(4), tolerance 1e-3 of the local cell size, "
           "steps <= 2 cells; ParaView 5.11 vtkStreamTracer RK4-5, cell-length steps 0.2 initial, 0.01..0.5, max error 1e-6, SMP backend Sequential. "
           "Seconds: median of %d runs, excluding file reading; ours include face adjacency and the seed grid, ParaView's Update() its locator. "
           "Distances: matched lines (by seed) resampled at 64 points by arc length over their common length, in local cell sizes "
           "(cbrt(6 V) of the tet, >= 0.1 longest edge); mean = mean over lines of the per-line mean, max over all samples. "
           "tolerance_1e-6: ours again at --tolerance 1e-6 (one run). length_ratio: our arc length / ParaView's; VTK's MaximumPropagation "
           "is not the polyline's arc length (its lines stopped by it measure 35..84 of 100 on disk_out_ref), ours is." % runs),
  "rows": rows}, indent=2))
PY
cat bench/results/streamlines.json
