#!/usr/bin/env bash
# Two server builds side by side: `tetrascope loadtest`, 1 client for DURATION
# seconds (default 10), frames of SIZE (default 1024x768), on the sample store
# (data/samples/disk_out_ref.vtk preprocessed as the server tests do), RUNS runs (default 3) of each binary, alternating so that both see the
# same background load; a fresh server per run. Writes each run and the medians to OUT
# (default bench/results/loadtest_compare.json).
#   [SIZE=WxH] bench/loadtest_compare.sh BEFORE_BIN AFTER_BIN [DURATION] [RUNS] [OUT]
set -euo pipefail
cd "$(dirname "$0")/.."
before="$1"
after="$2"
duration="${3:-10}"
runs="${4:-3}"
out="${5:-bench/results/loadtest_compare.json}"
size="${SIZE:-1024x768}"
mkdir -p bench/out/loadtest-compare
store=bench/out/loadtest-compare/disk
[[ -d $store ]] || "$before" preprocess data/samples/disk_out_ref.vtk -o $store --segment-tets 2000 --base-tets 3000 --progress none > /dev/null
port=18090
rows=()
for run in $(seq "$runs"); do
  for which in before after; do
    bin=$before
    [[ $which == after ]] && bin=$after
    "$bin" serve --data bench/out/loadtest-compare --port $port --workers 2 > bench/out/loadtest-compare/serve.log 2>&1 &
    server=$!
    for _ in $(seq 100); do curl -sf "http://127.0.0.1:$port/api/v1/health" > /dev/null && break; sleep 0.1; done
    j=$("$bin" loadtest --url "ws://127.0.0.1:$port/api/v1/session" --dataset disk --clients 1 --duration "$duration" --size "$size" --json | tail -1) || true
    kill $server
    wait $server 2>/dev/null || true
    rows+=("{\"binary\": \"$which\", \"run\": $run, \"result\": $j}")
  done
done
python3 - "$out" "$duration" "$(nproc)" "$(uptime)" "$size" "${rows[@]}" <<'PY'
import json, statistics, sys
out, duration, cores, load, size = sys.argv[1], float(sys.argv[2]), int(sys.argv[3]), sys.argv[4], sys.argv[5]
runs = [json.loads(r) for r in sys.argv[6:]]
for r in runs:
    r["result"].pop("per_client", None)
def median(which, key, sub=None):
    values = [r["result"][key][sub] if sub else r["result"][key] for r in runs if r["binary"] == which]
    return statistics.median(values)
summary = {}
for which in ("before", "after"):
    summary[which] = {"frames": median(which, "frames"), "total_fps": median(which, "total_fps"), "latency_p50_ms": median(which, "latency_ms", "p50"),
                      "latency_p95_ms": median(which, "latency_ms", "p95"), "bytes_per_s": median(which, "bytes_per_s"),
                      "errors": max(r["result"]["errors"] for r in runs if r["binary"] == which)}
json.dump({"benchmark": f"tetrascope loadtest, 1 client, orbit path, {size}, sample store (disk_out_ref, 44832 tets), serve --workers 2",
           "duration_s": duration, "machine": f"{cores} cores shared with other builds and tests running at the same time (noisy): load at the end {load.strip()}",
           "medians": summary, "runs": runs}, open(out, "w"), indent=1)
print(json.dumps(summary))
PY
