#!/usr/bin/env bash
# The service on loopback with frames bounded by time: `tetrascope loadtest` against
# `tetrascope serve --frame-ms F` on stores built with DEFAULT preprocess options (the ~1M and
# ~5M blades of make-large.sh and onera_m6_potential), 1024x768:
#  - 1 client orbit: input-to-frame latency p50/p99, fps, and the frame-time model's prediction
#    error (|measured - predicted| / measured over interaction frames, p50/p90, from /metrics);
#  - 1 client orbit-pause (orbit 3 s, pause 6 s, ...): the first frame after each resume
#    (p50/p99), release to the first refinement step and to the still; on the 5M blade the
#    steps of one pause are kept and each compared with the still (PSNR, bench/refine_psnr.py);
#  - 4 and 16 clients orbit: fps per client (min/median) and latency p50/p99.
# Each figure is the median of REPEATS runs (default 3), a fresh server per run. Results in
# bench/results/server.json. The stores are read from STORES (default /work/bigdata/time:
# blade1m.mt, blade5m.mt, onera_m6_potential.mt and, when there, blade20m.mt, made with
# `tetrascope preprocess IN -o OUT`). Once per script, on the 5M blade: orbit 3 s, pause 30 s
# (the still is reached), its refinement steps kept and compared with the still.
#   DURATION=20 REPEATS=3 FRAME_MS=60 bench/server_bench.sh
#   SWEEP="40 60 90" bench/server_bench.sh   only the 1-client orbit on the 5M blade per frame time
#                                             (bench/results/server-frame-ms.json)
set -euo pipefail
cd "$(dirname "$0")/.."
duration="${DURATION:-20}"
repeats="${REPEATS:-3}"
frame_ms="${FRAME_MS:-60}"
stores="${STORES:-/work/bigdata/time}"
bin="${BIN:-build/release/apps/tetrascope}"
out=bench/out/server-bench
rm -rf "$out" && mkdir -p "$out/data"
ln -sfn "$stores/blade1m.mt" "$out/data/blade1m"
ln -sfn "$stores/blade5m.mt" "$out/data/blade5m"
ln -sfn "$stores/onera_m6_potential.mt" "$out/data/onera_m6_potential"
datasets=(blade1m blade5m onera_m6_potential)
if [[ -d "$stores/blade20m.mt" ]]; then
  ln -sfn "$stores/blade20m.mt" "$out/data/blade20m"
  datasets+=(blade20m)
fi
load_before=$(cut -d' ' -f1-3 /proc/loadavg)
port=18080

# run NAME FRAME_MS LOADTEST-ARGS...: a fresh server, one loadtest; prints the loadtest JSON
# with the server's frame-time model figures added
run() {
  local fm=$1
  shift
  $bin serve --data "$out/data" --port $port --workers 2 --cache-mb 1024 --frame-ms "$fm" > "$out/serve.log" 2>&1 &
  local server=$!
  for _ in $(seq 100); do curl -sf "http://127.0.0.1:$port/api/v1/health" > /dev/null && break; sleep 0.2; done
  local j
  j=$($bin loadtest --url "ws://127.0.0.1:$port/api/v1/session" --size 1024x768 --json "$@" | tail -1) || true
  local metrics
  metrics=$(curl -sf "http://127.0.0.1:$port/metrics")
  kill $server
  wait $server 2> /dev/null || true
  python3 - "$j" "$metrics" << 'PY'
import json, re, sys
j = json.loads(sys.argv[1]); j.pop("per_client", None)
m = sys.argv[2]
def metric(name):
    found = re.search(r"^%s (\S+)" % re.escape(name), m, re.M)
    return float(found.group(1)) if found else None
j["cost_error_p50_percent"] = metric("tetrascope_frame_cost_error_p50_percent")
j["cost_error_p90_percent"] = metric("tetrascope_frame_cost_error_p90_percent")
j["frames_interrupted"] = metric("tetrascope_frames_interrupted_total")
print(json.dumps(j))
PY
}

if [[ -n "${SWEEP:-}" ]]; then
  rows=()
  for fm in $SWEEP; do
    for r in $(seq "$repeats"); do
      rows+=("$(run "$fm" --dataset blade5m --clients 1 --duration "$duration" | python3 -c "import json,sys; j=json.load(sys.stdin); j['frame_ms']=$fm; print(json.dumps(j))")")
      echo "${rows[-1]}"
    done
  done
  python3 - bench/results/server-frame-ms.json "$repeats" "${rows[@]}" << 'PY'
import json, sys, datetime, statistics
runs = [json.loads(r) for r in sys.argv[3:]]
table = {}
for fm in sorted({r["frame_ms"] for r in runs}):
    rs = [r for r in runs if r["frame_ms"] == fm]
    table[str(fm)] = {"latency_p50_ms": statistics.median(r["latency_ms"]["p50"] for r in rs), "latency_p99_ms": statistics.median(r["latency_ms"]["p99"] for r in rs),
                      "fps": statistics.median(r["total_fps"] for r in rs), "runs": len(rs)}
json.dump({"date": datetime.date.today().isoformat(), "machine": "2 cores, Mesa llvmpipe, loopback; load average (1, 5, 15 min) at the end: " + open("/proc/loadavg").read().split(" ", 3)[:3].__str__(),
           "what": "1 client orbit on the 5M blade (default store), 1024x768, per --frame-ms; medians of the runs", "by_frame_ms": table, "runs": runs},
          open(sys.argv[1], "w"), indent=1)
PY
  exit 0
fi

rows=()
for r in $(seq "$repeats"); do
  for dataset in "${datasets[@]}"; do
    rows+=("$(run "$frame_ms" --dataset $dataset --clients 1 --duration "$duration" | python3 -c "import json,sys; j=json.load(sys.stdin); j['run']='orbit-1'; print(json.dumps(j))")")
    echo "${rows[-1]}"
    rows+=("$(run "$frame_ms" --dataset $dataset --clients 1 --duration $((duration + 12)) --path orbit-pause --orbit 3 --pause 6 | python3 -c "import json,sys; j=json.load(sys.stdin); j['run']='resume'; print(json.dumps(j))")")
    echo "${rows[-1]}"
    for clients in 4 16; do
      rows+=("$(run "$frame_ms" --dataset $dataset --clients $clients --duration "$duration" | python3 -c "import json,sys; j=json.load(sys.stdin); j['run']='orbit-$clients'; print(json.dumps(j))")")
      echo "${rows[-1]}"
    done
  done
done

# one long pause on the 5M blade: release to the still, its steps kept
rows+=("$(run "$frame_ms" --dataset blade5m --clients 1 --duration 36 --path orbit-pause --orbit 3 --pause 30 --save-refinement "$out/steps-5m" | python3 -c "import json,sys; j=json.load(sys.stdin); j['run']='long-pause'; print(json.dumps(j))")")
echo "${rows[-1]}"
load_after=$(cut -d' ' -f1-3 /proc/loadavg)

# the refinement steps of that pause against its still (PSNR, dB)
steps_json="[]"
if [[ -f "$out/steps-5m/steps.json" ]]; then
  steps_json=$(pvpython bench/refine_psnr.py "$out/steps-5m" 2> /dev/null | tail -1)
fi

python3 - bench/results/server.json "$frame_ms" "$repeats" "$steps_json" "$load_before" "$load_after" "${rows[@]}" << 'PY'
import json, sys, datetime, statistics
frame_ms, repeats, steps = float(sys.argv[2]), int(sys.argv[3]), json.loads(sys.argv[4])
load_before, load_after = sys.argv[5], sys.argv[6]
runs = [json.loads(r) for r in sys.argv[7:]]
med = statistics.median
summary = {}
for ds in ["blade1m", "blade5m", "onera_m6_potential", "blade20m"]:
    s = {}
    o = [r for r in runs if r["dataset"] == ds and r["run"] == "orbit-1"]
    if o:
        s["orbit_1_client"] = {"latency_p50_ms": med(r["latency_ms"]["p50"] for r in o), "latency_p99_ms": med(r["latency_ms"]["p99"] for r in o),
                               "fps": med(r["total_fps"] for r in o), "cost_error_p50_percent": med(r["cost_error_p50_percent"] or 0 for r in o),
                               "cost_error_p90_percent": med(r["cost_error_p90_percent"] or 0 for r in o), "runs": len(o)}
    p = [r for r in runs if r["dataset"] == ds and r["run"] == "resume"]
    if p:
        s["orbit_pause_1_client"] = {"resume_first_frame_p50_ms": med(r["resume_first_frame_ms"]["p50"] for r in p),
                                     "resume_first_frame_p99_ms": med(r["resume_first_frame_ms"]["p99"] for r in p),
                                     "release_to_first_refinement_p50_ms": med(r["release_to_first_refinement_ms"]["p50"] for r in p),
                                     "release_to_still_p50_ms": med(r["release_to_still_ms"]["p50"] for r in p),
                                     "pauses_reaching_the_still": sum(r["pauses_reaching_the_still"] for r in p), "pauses": sum(r["pauses"] for r in p),
                                     "cost_error_p50_percent": med(r["cost_error_p50_percent"] or 0 for r in p),
                                     "cost_error_p90_percent": med(r["cost_error_p90_percent"] or 0 for r in p), "runs": len(p)}
    for c in (4, 16):
        m = [r for r in runs if r["dataset"] == ds and r["run"] == "orbit-%d" % c]
        if m:
            s["orbit_%d_clients" % c] = {"min_client_fps": med(r["min_client_fps"] for r in m), "mean_client_fps": med(r["total_fps"] / c for r in m),
                                         "latency_p50_ms": med(r["latency_ms"]["p50"] for r in m), "latency_p99_ms": med(r["latency_ms"]["p99"] for r in m),
                                         "clients_without_frames": max(r["clients_without_frames"] for r in m), "runs": len(m)}
    if s:
        summary[ds] = s
long_pause = next((r for r in runs if r["run"] == "long-pause"), None)
if long_pause:
    summary["blade5m"]["long_pause_1_client"] = {k: long_pause[k] for k in ("release_to_first_refinement_ms", "release_to_still_ms", "pauses_reaching_the_still", "pauses")}
first_within_35 = next((st for st in steps if st["still"] or (st.get("psnr_db_vs_still") or 0) >= 35), None)
json.dump({"date": datetime.date.today().isoformat(),
           "machine": "2 cores, Mesa llvmpipe, loopback; load average (1, 5, 15 min) before: %s, after: %s" % (load_before, load_after),
           "server": "tetrascope serve --workers 2 --cache-mb 1024 --frame-ms %g (interaction: tets and pixels by the frame-time model, at most 15000 tets, scale 0.375, JPEG q60; refinement: steps of frame_ms*4^(k+1) ms up to 500000 tets, JPEG q90)" % frame_ms,
           "stores": "default preprocess options (see the manifests for the coarsest levels)",
           "repeats": repeats, "summary": summary,
           "refinement_5m_one_pause": {"steps": steps, "first_within_35db_of_still_ms": first_within_35["ms_since_release"] if first_within_35 else None},
           "runs": runs}, open(sys.argv[1], "w"), indent=1)
PY
echo "bench/results/server.json written"
