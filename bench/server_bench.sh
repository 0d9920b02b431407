#!/usr/bin/env bash
# The service on loopback: `tetrascope loadtest` against `tetrascope serve` with the ~1M and
# ~5M blade stores (built with a small coarsest level, --base-tets 10000, so interaction
# frames can meet their budget), 1024x768, orbit path, 1 / 4 / 16 clients for DURATION
# seconds each (default 20). Records input-to-frame latency p50/p95/p99, fps (total, per
# client min/max), KB per interaction and still frame, errors and the server's RSS (before,
# after, peak) in bench/results/server.json.
#   SCALE=0.5 CLIENTS="1" bench/server_bench.sh   another interaction scale (results in
#   bench/results/server-scale-0.5.json), other client counts
set -euo pipefail
cd "$(dirname "$0")/.."
duration="${1:-20}"
scale="${SCALE:-0.375}"
clients_list="${CLIENTS:-1 4 16}"
results=bench/results/server.json
[[ "$scale" == "0.375" ]] || results="bench/results/server-scale-$scale.json"
cmake --build --preset release -j "$(nproc)" --target tetrascope > /dev/null
bin=build/release/apps/tetrascope
mkdir -p bench/out/serve-data
[[ -d bench/out/blade1m-small-base.mt ]] || $bin preprocess bench/out/blade1m.vtk -o bench/out/blade1m-small-base.mt --base-tets 10000 --force --progress none
[[ -d bench/out/blade5m-small-base.mt ]] || $bin preprocess bench/out/blade5m.vtk -o bench/out/blade5m-small-base.mt --base-tets 10000 --force --progress none
ln -sfn "$PWD/bench/out/blade1m-small-base.mt" bench/out/serve-data/blade1m
ln -sfn "$PWD/bench/out/blade5m-small-base.mt" bench/out/serve-data/blade5m
port=18080
rows=()
for dataset in blade1m blade5m; do
  for clients in $clients_list; do
    # a fresh server per run: RSS growth is that run's
    $bin serve --data bench/out/serve-data --port $port --workers 2 --cache-mb 1024 --interaction-scale "$scale" > bench/out/serve.log 2>&1 &
    server=$!
    for _ in $(seq 50); do curl -sf "http://127.0.0.1:$port/api/v1/health" > /dev/null && break; sleep 0.2; done
    j=$($bin loadtest --url "ws://127.0.0.1:$port/api/v1/session" --dataset $dataset --clients $clients --duration "$duration" --size 1024x768 --json | tail -1) || true
    metrics=$(curl -sf "http://127.0.0.1:$port/metrics")
    kill $server; wait $server 2>/dev/null || true
    rows+=("$(python3 -c "
import json, sys, re
j = json.loads(sys.argv[1]); j.pop('per_client'); j['store'] = '$dataset'
# mean ms per frame of each step, from the server's histograms (_sum / _count)
m = sys.argv[2]
for step in ['cut_update', 'assemble', 'upload', 'draw', 'encode']:
    total = float(re.search(r'^tetrascope_%s_ms_sum (\\S+)' % step, m, re.M).group(1))
    count = float(re.search(r'^tetrascope_%s_ms_count (\\S+)' % step, m, re.M).group(1))
    j['server_mean_%s_ms' % step] = total / count if count else None
j['frames_dropped'] = int(float(re.search(r'^tetrascope_frames_dropped_total (\\S+)', m, re.M).group(1)))
print(json.dumps(j))" "$j" "$metrics")")
    echo "${rows[-1]}"
  done
done
python3 - "$results" "$scale" "${rows[@]}" <<'PY'
import json, sys, datetime
json.dump({"date": datetime.date.today().isoformat(), "machine": "2 cores, Mesa llvmpipe, loopback",
           "server": "tetrascope serve --workers 2 --cache-mb 1024 --interaction-scale %s (interaction: 15000 tets, JPEG q60; still: 500000 tets, q90)" % sys.argv[2],
           "runs": [json.loads(r) for r in sys.argv[3:]]}, open(sys.argv[1], "w"), indent=2)
PY
