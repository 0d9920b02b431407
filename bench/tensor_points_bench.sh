#!/usr/bin/env bash
# A tensor field's points (§7.4.2) at interactive rates in the server: `tetrascope loadtest`
# (1 client, orbit, 1024x768, the server's interaction budget and frame time) against `tetrascope
# serve` on a 504,000-tet stress field (Lamé's thick-walled cylinder, bench/tensor_lame.py's
# quarter wall, 40 x 60 x 35 hexahedra), each session drawing
#   dvr            the volume alone (the anchor)
#   dvr+tensors    the volume with the tensor's tubes and surfaces (default seeding)
#   slice+tensors  the tubes and surfaces alone
# fps and input-to-frame latency p50/p99, each the median of REPEATS runs (default 3), a fresh
# server per run, the modes alternated within each repeat. Also, on the whole mesh file:
# `render --mode tensors --json` (tracing and sampling time, points) REPEATS times, and the draw
# time of a frame of points alone (`--orbit 8`, median). Results in bench/results/tensor_points.json.
#   DURATION=15 REPEATS=3 bench/tensor_points_bench.sh
set -euo pipefail
cd "$(dirname "$0")/.."
duration="${DURATION:-15}"
repeats="${REPEATS:-3}"
bin="${BIN:-build/release/apps/tetrascope}"
out=bench/out/tensor-points
mkdir -p "$out/data"
mesh="$out/lame_504k.vtk"
[[ -f "$mesh" ]] || /usr/bin/python3 -c "import sys; sys.path.insert(0, 'bench'); import tensor_lame; tensor_lame.write_mesh('$mesh', nr=40, nt=60, nz=35)"
[[ -d "$out/data/lame" ]] || $bin preprocess "$mesh" -o "$out/data/lame" --progress none
load_before=$(cut -d' ' -f1-3 /proc/loadavg)
port=18090
echo "[]" > "$out/runs.json"
for r in $(seq "$repeats"); do
  for mode in dvr dvr+tensors slice+tensors; do
    $bin serve --data "$out/data" --port $port --workers 2 > "$out/serve.log" 2>&1 &
    server=$!
    for _ in $(seq 100); do curl -sf "http://127.0.0.1:$port/api/v1/health" > /dev/null && break; sleep 0.2; done
    j=$($bin loadtest --url "ws://127.0.0.1:$port/api/v1/session" --dataset lame --size 1024x768 --duration "$duration" --mode "$mode" --json | tail -1) || true
    kill $server
    wait $server 2> /dev/null || true
    python3 - "$out/runs.json" "$mode" "$j" << 'PY'
import json, sys
runs = json.load(open(sys.argv[1]))
j = json.loads(sys.argv[3]); j.pop("per_client", None)
runs.append({"mode": sys.argv[2], "fps": j["total_fps"], "latency_p50_ms": j["latency_ms"]["p50"], "latency_p99_ms": j["latency_ms"]["p99"], "errors": j.get("errors")})
json.dump(runs, open(sys.argv[1], "w"))
PY
  done
  $bin render "$mesh" -o "$out/tensors.png" --mode tensors --size 1024x768 --json > "$out/render-$r.json"
done
$bin render "$mesh" -o "$out/orbit.png" --mode tensors --size 1024x768 --orbit 8 --json > "$out/orbit.json"
python3 - "$out" "$repeats" "$duration" "$load_before" "$(cut -d' ' -f1-3 /proc/loadavg)" "$(git rev-parse --short HEAD)" << 'PY'
import glob, json, statistics, sys
out, repeats, duration, load_before, load_after, commit = sys.argv[1:]
runs = json.load(open(f"{out}/runs.json"))
modes = {}
for m in ("dvr", "dvr+tensors", "slice+tensors"):
    rs = [r for r in runs if r["mode"] == m]
    modes[m] = {k: statistics.median(r[k] for r in rs) for k in ("fps", "latency_p50_ms", "latency_p99_ms")}
    modes[m]["runs"] = len(rs)
renders = [json.load(open(f)) for f in sorted(glob.glob(f"{out}/render-*.json"))]
orbit = json.load(open(f"{out}/orbit.json"))
t = renders[-1]["tensors"]
record = {
    "commit": commit, "load_before": load_before, "load_after": load_after, "repeats": int(repeats), "duration_s": float(duration),
    "mesh": {"name": "lame_504k (bench/tensor_lame.py, 40 x 60 x 35 hexahedra in 6 tets)", "tets": 504000},
    "server_1_client_orbit_1024x768": modes,
    "ratio_fps_dvr_tensors_to_dvr": modes["dvr+tensors"]["fps"] / modes["dvr"]["fps"],
    "goal_fps": 10, "goal_met": modes["dvr+tensors"]["fps"] >= 10 and modes["slice+tensors"]["fps"] >= 10,
    "render_whole_mesh": {"trace_ms_median": statistics.median(r["tensors"]["trace_ms"] for r in renders), "trace_ms_runs": [r["tensors"]["trace_ms"] for r in renders],
                          "tubes": t["tubes"], "surfaces": t["surfaces"], "tube_points": t["tube_points"], "surface_points": t["surface_points"], "spacing": t["spacing"],
                          "frame_ms_median": orbit["median_ms"], "frame_draw_ms_median": orbit["median_draw_ms"], "frames": orbit["frames"]},
    "method": "loadtest: 1 client, orbit path, 30 camera moves/s, a fresh `serve --workers 2` per run, modes alternated in each repeat, medians of the repeats; render: whole processes on the mesh file, the tracing time from --json; Mesa llvmpipe on 2 shared cores",
}
json.dump(record, open("bench/results/tensor_points.json", "w"), indent=1)
print(json.dumps({k: record[k] for k in ("server_1_client_orbit_1024x768", "ratio_fps_dvr_tensors_to_dvr", "goal_met", "render_whole_mesh")}, indent=1))
PY
