#!/usr/bin/env bash
# Two `tetrascope serve` replicas behind real haproxy (scripts/replicas): `tetrascope loadtest`
# through haproxy gets frames from both, and when the replica holding sessions is killed
# mid-run its sessions reconnect through haproxy to the other with no errors.
#   tests/deploy/replicas_test.sh TETRASCOPE_BINARY SAMPLE_MESH
set -euo pipefail
bin="$(realpath "$1")"
mesh="$(realpath "$2")"
cd "$(dirname "$0")/../.."
command -v haproxy > /dev/null || { echo "haproxy is missing: scripts/install-deps installs it"; exit 1; }
work="$(mktemp -d -t tetrascope-replicas-test.XXXXXX)"
set_pid=""
cleanup() {
  [[ -n "$set_pid" ]] && kill "$set_pid" 2> /dev/null && wait "$set_pid" 2> /dev/null
  rm -rf "$work"
}
trap cleanup EXIT
"$bin" preprocess "$mesh" -o "$work/data/disk" --segment-tets 2000 --base-tets 3000 --progress none > /dev/null
port=$((20000 + RANDOM % 20000))
TETRA_REPLICAS_DIR="$work/set" TETRASCOPE="$bin" scripts/replicas --data "$work/data" --replicas 2 --port "$port" -- --workers 1 > "$work/replicas.log" 2>&1 &
set_pid=$!
for _ in $(seq 300); do grep -q "behind haproxy" "$work/replicas.log" 2> /dev/null && break; sleep 0.1; done
grep -q "behind haproxy" "$work/replicas.log" || { cat "$work/replicas.log"; exit 1; }

# 4 clients for 10 s; after 4 s the replica with the most sessions is killed
( sleep 4
  best=1 most=-1
  for k in 1 2; do
    n=$(curl -sf "http://127.0.0.1:$((port + k))/api/v1/health" | python3 -c 'import json,sys; print(json.load(sys.stdin)["sessions"])' || echo 0)
    if ((n > most)); then best=$k most=$n; fi
  done
  echo "$best $most" > "$work/killed"
  kill "$(cat "$work/set/replica-$best.pid")" ) &
killer=$!
# loadtest exits 1 on any error or a client without frames: the check below says which
"$bin" loadtest --url "ws://127.0.0.1:$port/api/v1/session" --dataset disk --clients 4 --duration 10 --size 320x240 --json > "$work/loadtest.json" || true
wait "$killer"
python3 - "$work/loadtest.json" "$work/killed" << 'PY' || { echo "--- replicas log (last 40 lines)"; tail -n 40 "$work/replicas.log"; exit 1; }
import json, sys
j = json.loads(open(sys.argv[1]).read().strip().splitlines()[-1])
killed, sessions = map(int, open(sys.argv[2]).read().split())
print(json.dumps({k: j[k] for k in ("frames", "errors", "reconnects", "clients_without_frames", "total_fps")}), "killed replica", killed, "holding", sessions, "sessions")
problems = []
if sessions < 1: problems.append("no replica held a session when one was killed (haproxy did not balance onto it)")
if j["errors"] != 0: problems.append("errors: %s" % j["errors"])
if j["reconnects"] < sessions: problems.append("reconnects %s < sessions lost %s" % (j["reconnects"], sessions))
if j["clients_without_frames"] != 0: problems.append("clients without frames: %s" % j["clients_without_frames"])
for i, c in enumerate(j["per_client"]):
    if c["failure"]: problems.append("client %d failed: %s" % (i, c["failure"]))
    elif c["errors"]: problems.append("client %d: %s errors" % (i, c["errors"]))
if problems:
    print("FAILED:", "; ".join(problems)); sys.exit(1)
print("ok: every session lost with the replica reconnected through haproxy")
PY
