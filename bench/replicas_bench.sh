#!/usr/bin/env bash
# Serving replicas behind haproxy (scripts/replicas, docs/deploy.md): `tetrascope loadtest`
# through haproxy on loopback, ONERA M6 (onera_m6_potential preprocessed with the defaults),
# 1024x768, orbit, CLIENTS clients (default 8) for DURATION seconds (default 20):
#   1. one replica with one render worker, directly (no haproxy): the anchor;
#   2. one replica with one render worker behind haproxy (the proxy's cost);
#   3. two replicas with one render worker each behind haproxy (the scaling);
#   4. two replicas behind haproxy, replica 2 killed DURATION/2 into the run: its sessions
#      reconnect through haproxy to replica 1 (errors, reconnects, clients without frames).
# Runs each of 1-3 RUNS times (default 3) and reports medians. Results in
# bench/results/replicas.json.
set -euo pipefail
cd "$(dirname "$0")/.."
duration="${DURATION:-20}"
clients="${CLIENTS:-8}"
runs="${RUNS:-3}"
cmake --build --preset release -j "$(nproc)" --target tetrascope > /dev/null
bin=build/release/apps/tetrascope
mkdir -p bench/out/replicas-data
[[ -d bench/out/replicas-data/onera ]] || $bin preprocess ../shared/data/onera_m6_potential.vtk -o bench/out/replicas-data/onera --force --progress none
port=18600
loadtest() {  # URL_PORT -> one JSON line
  $bin loadtest --url "ws://127.0.0.1:$1/api/v1/session" --dataset onera --clients "$clients" --duration "$duration" --size 1024x768 --json | tail -1
}
wait_health() { for _ in $(seq 100); do curl -sf "http://127.0.0.1:$1/api/v1/health" > /dev/null && return 0; sleep 0.2; done; return 1; }
start_replicas() {  # N -> sets set_pid, set_dir
  set_dir=$(mktemp -d -t replicas-bench.XXXXXX)
  TETRA_REPLICAS_DIR=$set_dir TETRASCOPE=$bin scripts/replicas --data bench/out/replicas-data --replicas "$1" --port $port -- --workers 1 > "$set_dir/out.log" 2>&1 &
  set_pid=$!
  wait_health $port
  for _ in $(seq 50); do grep -q "behind haproxy" "$set_dir/out.log" && break; sleep 0.2; done
}
stop_replicas() { kill "$set_pid" 2> /dev/null; wait "$set_pid" 2> /dev/null || true; }
rows=()
for ((run = 1; run <= runs; ++run)); do
  $bin serve --data bench/out/replicas-data --port $((port + 50)) --workers 1 > bench/out/replicas-direct.log 2>&1 &
  direct=$!
  wait_health $((port + 50))
  rows+=("$(python3 -c 'import json,sys; j=json.loads(sys.argv[1]); j.pop("per_client"); j["setup"]="1 replica, direct"; j["run"]=int(sys.argv[2]); print(json.dumps(j))' "$(loadtest $((port + 50)))" "$run")")
  kill $direct; wait $direct 2> /dev/null || true
  for n in 1 2; do
    start_replicas $n
    rows+=("$(python3 -c 'import json,sys; j=json.loads(sys.argv[1]); j.pop("per_client"); j["setup"]=sys.argv[3]; j["run"]=int(sys.argv[2]); print(json.dumps(j))' "$(loadtest $port)" "$run" "$n replica(s) behind haproxy")")
    stop_replicas
  done
done
# one replica killed mid-run
start_replicas 2
( sleep "$((duration / 2))"; kill "$(cat "$set_dir/replica-2.pid")" ) &
killed=$(loadtest $port)
stop_replicas
python3 - bench/results/replicas.json "$clients" "$duration" "$killed" "${rows[@]}" <<'PY'
import json, sys, datetime, statistics
out, clients, duration, killed = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), json.loads(sys.argv[4])
rows = [json.loads(r) for r in sys.argv[5:]]
summary = {}
for setup in dict.fromkeys(r["setup"] for r in rows):
    rs = [r for r in rows if r["setup"] == setup]
    summary[setup] = {"runs": len(rs), "total_fps_median": statistics.median(r["total_fps"] for r in rs),
                      "p50_ms_median": statistics.median(r["latency_ms"]["p50"] for r in rs),
                      "p99_ms_median": statistics.median(r["latency_ms"]["p99"] for r in rs),
                      "errors": sum(r["errors"] for r in rs)}
anchor = summary["1 replica, direct"]["total_fps_median"]
for s in summary.values(): s["fps_over_direct"] = s["total_fps_median"] / anchor if anchor else None
killed_row = {k: killed.get(k) for k in ("total_fps", "errors", "reconnects", "clients_without_frames", "latency_ms", "frames")}
json.dump({"date": datetime.date.today().isoformat(),
           "machine": "2 cores, Mesa llvmpipe, loopback; each replica `serve --workers 1`; haproxy 2.6 (scripts/replicas)",
           "dataset": "onera_m6_potential, preprocess defaults", "clients": clients, "duration_s": duration, "size": "1024x768",
           "summary": summary, "replica_killed_mid_run": killed_row, "runs": rows}, open(out, "w"), indent=2)
print(json.dumps({"summary": summary, "replica_killed_mid_run": killed_row}, indent=2))
PY
