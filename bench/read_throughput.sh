#!/usr/bin/env bash
# Read throughput and peak RSS of tetrascope's readers next to ParaView's (pvpython) on the
# same files, in one run. Writes bench/results/read_throughput.json and prints a table.
#
#   bench/read_throughput.sh [MESH.vtk]
#
# Default mesh: the ~5M-tet turbine blade of shared/data/make/make-large.sh (analytic
# field), generated into bench/out/ when missing (about 1.5 min). The VTU versions are
# written by ParaView's own XML writer. Each reader runs once to warm the page cache, then
# three times in fresh processes; the fastest run counts, for every tool alike.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps --bench
cmake --preset release > /dev/null
cmake --build --preset release -j "$(nproc)" --target read_bench > /dev/null
out=bench/out
mkdir -p "$out" bench/results
mesh="${1:-$out/blade5m.vtk}"
if [[ ! -f "$mesh" ]]; then
  echo "generating $mesh with make-large.sh 5000000 (analytic field)"
  bash ../shared/data/make/make-large.sh 5000000 "$(realpath -m "$mesh")" analytic
fi
base="$out/$(basename "${mesh%.vtk}")"
[[ -f "$base.vtu" ]] || pvpython bench/to_vtu.py "$mesh" "$base.vtu" raw 2>/dev/null
[[ -f "$base.zlib.vtu" ]] || pvpython bench/to_vtu.py "$mesh" "$base.zlib.vtu" zlib 2>/dev/null

measure() {  # measure LABEL COMMAND... -> JSON: the command's own line (fastest of 3 runs) + peak_rss_kb
  local label="$1"; shift
  local log; log="$(mktemp)"
  "$@" > /dev/null 2>&1 || true   # warm the page cache
  for run in 1 2 3; do
    /usr/bin/time -f "%M" -o "$log.$run" "$@" 2>/dev/null | tail -1 > "$log.$run.json"
  done
  python3 - "$label" "$log" <<'PY'
import json, sys
label, log = sys.argv[1:3]
runs = []
for run in (1, 2, 3):
    d = json.load(open(f"{log}.{run}.json"))
    d["peak_rss_kb"] = int(open(f"{log}.{run}").read().split()[-1])
    runs.append(d)
best = min(runs, key=lambda d: d["seconds"])
best["peak_rss_kb"] = max(d["peak_rss_kb"] for d in runs)
best["label"] = label
print(json.dumps(best))
PY
  rm -f "$log" "$log".*
}

baseline=$(measure paraview_baseline pvpython bench/paraview_read.py --baseline)
rows=()
for file in "$mesh" "$base.vtu" "$base.zlib.vtu"; do
  rows+=("$(measure tetrascope_stream build/release/bench/read_bench "$file" stream)")
  rows+=("$(measure tetrascope_load build/release/bench/read_bench "$file" load)")
  rows+=("$(measure paraview pvpython bench/paraview_read.py "$file")")
done

python3 - "$baseline" "${rows[@]}" <<'PY' "$mesh" "$base.vtu" "$base.zlib.vtu"
import json, os, subprocess, sys, datetime
baseline = json.loads(sys.argv[1])
rows = [json.loads(r) for r in sys.argv[2:11]]
files = sys.argv[11:14]
results = {"date": datetime.date.today().isoformat(), "machine": "2 cores, 24 GB, Debian 12",
           "method": "fastest of three runs each after a warm-up run (warm page cache); ParaView times reader.Update() only; "
                     "peak RSS of the whole process; ParaView's RSS also given less its pvpython+VTK baseline",
           "paraview_baseline_rss_kb": baseline["peak_rss_kb"], "files": []}
print(f"{'file':28} {'reader':18} {'s':>7} {'MB/s':>7} {'Mtets/s':>8} {'peak RSS MB':>12} {'vs ParaView':>11}")
for i, path in enumerate(files):
    stream, load, pv = rows[3 * i: 3 * i + 3]
    size = os.path.getsize(path)
    tets = stream["tetrahedra"]
    entry = {"file": os.path.basename(path), "bytes": size, "vertices": stream["vertices"], "tetrahedra": tets,
             "mesh_bytes_in_memory": load["mesh_bytes"]}
    for name, r in (("tetrascope_stream", stream), ("tetrascope_load", load), ("paraview", pv)):
        entry[name] = {"seconds": r["seconds"], "mb_per_s": size / 1e6 / r["seconds"], "mtets_per_s": tets / 1e6 / r["seconds"],
                       "peak_rss_mb": r["peak_rss_kb"] / 1024}
        speedup = pv["seconds"] / r["seconds"]
        entry[name]["speedup_vs_paraview"] = speedup
        print(f"{entry['file']:28} {name:18} {r['seconds']:7.3f} {size/1e6/r['seconds']:7.0f} {tets/1e6/r['seconds']:8.2f} "
              f"{r['peak_rss_kb']/1024:12.1f} {speedup:10.2f}x")
    entry["paraview"]["peak_rss_mb_less_baseline"] = (pv["peak_rss_kb"] - baseline["peak_rss_kb"]) / 1024
    entry["stream_rss_fraction_of_mesh"] = stream["peak_rss_kb"] * 1024 / load["mesh_bytes"]
    print(f"{'':28} streaming peak RSS = {100*entry['stream_rss_fraction_of_mesh']:.0f}% of the mesh in memory "
          f"({load['mesh_bytes']/2**20:.0f} MB); ParaView RSS less baseline {entry['paraview']['peak_rss_mb_less_baseline']:.0f} MB")
    results["files"].append(entry)
with open("bench/results/read_throughput.json", "w") as f:
    json.dump(results, f, indent=2)
print("wrote bench/results/read_throughput.json")
PY
