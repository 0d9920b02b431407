#!/usr/bin/env bash
# Serving a store under a memory limit smaller than the store: `tetrascope serve
# --workers 2 --cache-mb C --frame-ms F` is started inside a memory cgroup limited to LIMIT_MB
# (default 300), a fresh server (and group) per run, and driven by one client at 1024x768:
#  - orbit:       `tetrascope loadtest --path orbit` (a turn in 6 s), DURATION s;
#  - zoom:        bench/serve_memory_limit_zoom.py (loadtest has no zoom path): dolly towards
#                 the target to 0.2 of the opening distance and back every 8 s while turning
#                 once in 24 s, DURATION s;
#  - orbit-pause: `loadtest --path orbit-pause --orbit 3 --pause 6`, DURATION+12 s: the first
#                 frame after each resume (p50/p99), release to the still;
#  - zoom-pause:  the zoom path moving 3 s, pausing 6 s, DURATION+12 s (resumes zoomed in,
#                 after refinements that paged in fine segments).
# Per run: latency p50/p99 and fps (as loadtest measures them), resume first frame p50/p99,
# the segment cache from /metrics (hits, misses, evictions, resident bytes; all and per
# dataset: hit rate = hits / (hits + misses) over the run), page-ins (the group's memory.stat
# pgmajfault and pgpgin deltas, the server's /proc/PID/io read_bytes and /proc/PID/stat
# majflt deltas, per second of the run), the group's peak usage and failcnt, OOM kills and
# whether the server survived. The page cache is dropped before each run when permitted
# (`sync; echo 3 > /proc/sys/vm/drop_caches`, root), so the store's pages come from the disk
# and are charged to the group. With BASELINE=1 (default) every run is repeated in a group
# without a limit, for comparison on the same machine at the same time.
# Results: bench/results/serve_memory_limit.json (medians of REPEATS, the raw runs).
#
#   bench/serve_memory_limit.sh STORE [LIMIT_MB]
#   DURATION=20 REPEATS=2 CACHE_MB=LIMIT/2 FRAME_MS=60 WORKERS=2 SERVE_OPTS="" KINDS="orbit zoom orbit-pause zoom-pause" BASELINE=1 METHOD=auto BIN=... OUT_JSON=...
#
# How the limit is applied (METHOD=auto picks the first that works, and says which):
#  - systemd: when systemd is PID 1 and systemd-run exists:
#      systemd-run --scope -p MemoryMax=LIMITM -p MemorySwapMax=0 tetrascope serve ...
#  - cgroup2: a group under the unified hierarchy (/sys/fs/cgroup with "memory" in
#      cgroup.controllers): memory.max = LIMIT, memory.swap.max = 0;
#  - cgroup1: a group under the v1 memory controller (/sys/fs/cgroup/memory):
#      memory.limit_in_bytes = LIMIT and, when there is swap, memory.memsw.limit_in_bytes =
#      LIMIT (no swapping out instead of limiting).
# For cgroup1/cgroup2 the server is started as
#   sh -c 'echo $$ > GROUP/cgroup.procs; exec tetrascope serve ...'
# so it (and the render workers' threads) is in the group from its first byte; the group is
# emptied and removed at exit (trap). Needs root (or a delegated group) for cgroup1/cgroup2.
#
# What --cache-mb bounds: the segment cache's bytes (each cached segment's mapping of
# segments.bin plus its decoded arrays, storage::MappedSegment::mapped_bytes), not the
# process: Mesa/LLVM, render workers' scenes and framebuffers, the DAG and the heap come on
# top (an idle server that has drawn 1024x768 holds ~120-230 MB, see bench/README.md "Idle memory").
# Mapped segment pages are page cache charged to the group: under the limit the kernel reclaims
# them and they are read again (page-ins); anonymous memory (decoded arrays, heap) cannot go
# anywhere without swap, so a limit below it ends in an OOM kill.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
if [[ $# -lt 1 || ! -d "$1" ]]; then
  echo "usage: $0 STORE_DIR [LIMIT_MB]   (env: DURATION REPEATS CACHE_MB FRAME_MS BASELINE METHOD BIN OUT_JSON)" >&2
  exit 2
fi
store=$(cd "$1" && pwd)
limit_mb="${2:-300}"
duration="${DURATION:-20}"
repeats="${REPEATS:-2}"
cache_mb="${CACHE_MB:-$((limit_mb / 2))}"
frame_ms="${FRAME_MS:-60}"
workers="${WORKERS:-2}"
kinds="${KINDS:-orbit zoom orbit-pause zoom-pause}"
serve_opts="${SERVE_OPTS:-}"
baseline="${BASELINE:-1}"
method="${METHOD:-auto}"
bin="${BIN:-build/release/apps/tetrascope}"
[[ "$bin" = /* ]] || bin="$root/$bin"
out_json="${OUT_JSON:-bench/results/serve_memory_limit.json}"
zoom="$root/bench/serve_memory_limit_zoom.py"
out=bench/out/serve-memory-limit
port="${PORT:-18290}"
name=$(basename "$store" .mt)
rm -rf "$out" && mkdir -p "$out/data" "$out/runs"
ln -sfn "$store" "$out/data/$name"
tag="tetrascope-memlimit-$$"

# ---- how the limit is applied ----------------------------------------------------------
v1=/sys/fs/cgroup/memory
# cgroup v1: memsw (memory + swap) is limited too only when there is swap to limit: with memsw
# limited, the charge fails on the memsw counter first and (kernel 6.18 here) neither
# memory.failcnt nor memory.memsw.failcnt counts it
memsw=0
[[ -f $v1/memory.memsw.limit_in_bytes && "$(awk '/^SwapTotal:/ {print $2}' /proc/meminfo)" != 0 ]] && memsw=1
v2=/sys/fs/cgroup
pick_method() {
  if [[ "$(cat /proc/1/comm 2> /dev/null)" == systemd ]] && command -v systemd-run > /dev/null &&
    systemd-run --scope --quiet -p MemoryMax=64M true 2> /dev/null; then
    echo systemd
  elif [[ -f $v2/cgroup.controllers ]] && grep -qw memory $v2/cgroup.controllers && mkdir "$v2/$tag-probe" 2> /dev/null; then
    rmdir "$v2/$tag-probe"
    echo cgroup2
  elif [[ -f $v1/memory.limit_in_bytes ]] && mkdir "$v1/$tag-probe" 2> /dev/null; then
    rmdir "$v1/$tag-probe"
    echo cgroup1
  else
    echo none
  fi
}
[[ "$method" == auto ]] && method=$(pick_method)
if [[ "$method" == none ]]; then
  echo "no way to limit memory here: not root, no writable memory cgroup (v1 or v2), no systemd as PID 1" >&2
  exit 1
fi
case $method in
  systemd) how="systemd-run --scope -p MemoryMax=${limit_mb}M -p MemorySwapMax=0 (the scope's cgroup read for the figures)" ;;
  cgroup2) how="cgroup v2 group $v2/$tag-N: memory.max=${limit_mb}M, memory.swap.max=0; the server started as sh -c 'echo \$\$ > GROUP/cgroup.procs; exec tetrascope serve ...'" ;;
  cgroup1) how="cgroup v1 group $v1/$tag-N: memory.limit_in_bytes=${limit_mb}M$([[ $memsw == 1 ]] && echo ", memory.memsw.limit_in_bytes=${limit_mb}M" || echo " (no swap: memsw not set)"); the server started as sh -c 'echo \$\$ > GROUP/cgroup.procs; exec tetrascope serve ...'" ;;
esac
echo "memory limit: $method: $how"

# drop the page cache (so the store's pages are read from the disk and charged to the group)
drop_caches() {
  sync
  if echo 3 > /proc/sys/vm/drop_caches 2> /dev/null; then echo dropped; else echo "not permitted"; fi
}
drop_note=$(drop_caches)
echo "page cache before each run: $drop_note"

server=""
group=""
unit=""
# alive PID: running (a killed child stays a zombie until waited for, and kill -0 finds it)
alive() { [[ -r /proc/$1/stat ]] && [[ "$(sed 's/.*) //' "/proc/$1/stat" | cut -d' ' -f1)" != Z ]]; }
cleanup() {
  if [[ -n "$server" ]] && alive "$server"; then
    kill "$server" 2> /dev/null || true
    wait "$server" 2> /dev/null || true
  fi
  server=""
  if [[ -n "$group" && -d "$group" && "$method" != systemd ]]; then
    [[ -f "$group/memory.force_empty" ]] && echo 0 > "$group/memory.force_empty" 2> /dev/null || true
    rmdir "$group" 2> /dev/null || true
  fi
  group=""
  if [[ -n "$unit" ]]; then
    systemctl stop "$unit" 2> /dev/null || true
  fi
  unit=""
}
trap 'cleanup' EXIT
trap 'exit 130' INT TERM

# start_server LIMIT_MB|none N: a fresh server in a fresh group; sets server, group
start_server() {
  local lim=$1 n=$2
  local cmd=("$bin" serve --data "$out/data" --port "$port" --workers "$workers" --cache-mb "$cache_mb" --frame-ms "$frame_ms")
  # shellcheck disable=SC2206
  [[ -n "$serve_opts" ]] && cmd+=($serve_opts)
  case $method in
    systemd)
      unit="$tag-$n.scope"
      local props=(-p MemoryAccounting=yes)
      [[ $lim != none ]] && props+=(-p "MemoryMax=${lim}M" -p MemorySwapMax=0)
      systemd-run --scope --quiet --unit="$unit" "${props[@]}" "${cmd[@]}" > "$out/runs/serve-$n.log" 2>&1 &
      server=$!
      sleep 0.5
      local rel
      rel=$(awk -F: '$2 == "" || $2 ~ /(^|,)memory(,|$)/ {print $3}' "/proc/$server/cgroup" | tail -1)
      group=$([[ -f $v1/memory.limit_in_bytes ]] && echo "$v1$rel" || echo "$v2$rel")
      ;;
    cgroup2)
      group="$v2/$tag-$n"
      mkdir "$group"
      grep -qw memory "$v2/cgroup.subtree_control" || echo +memory > "$v2/cgroup.subtree_control"
      if [[ $lim != none ]]; then
        echo "${lim}M" > "$group/memory.max"
        [[ -f "$group/memory.swap.max" ]] && echo 0 > "$group/memory.swap.max"
      fi
      sh -c 'echo $$ > "$0/cgroup.procs"; exec "$@"' "$group" "${cmd[@]}" > "$out/runs/serve-$n.log" 2>&1 &
      server=$!
      ;;
    cgroup1)
      group="$v1/$tag-$n"
      mkdir "$group"
      if [[ $lim != none ]]; then
        echo "${lim}M" > "$group/memory.limit_in_bytes"
        [[ $memsw == 1 ]] && echo "${lim}M" > "$group/memory.memsw.limit_in_bytes"
      fi
      sh -c 'echo $$ > "$0/cgroup.procs"; exec "$@"' "$group" "${cmd[@]}" > "$out/runs/serve-$n.log" 2>&1 &
      server=$!
      ;;
  esac
  for _ in $(seq 150); do
    curl -sf "http://127.0.0.1:$port/api/v1/health" > /dev/null && return 0
    alive "$server" || return 1
    sleep 0.2
  done
  return 1
}

# snapshot: the group's memory figures, the server's I/O and faults, /metrics, load; one JSON line
snapshot() {
  python3 - "$group" "$server" "$port" << 'PY'
import json, os, re, sys, time, urllib.request
group, pid, port = sys.argv[1], sys.argv[2], sys.argv[3]
def read(path):
    try:
        with open(path) as f: return f.read()
    except OSError: return None
def kv(text):
    out = {}
    for line in (text or "").splitlines():
        p = line.split()
        if len(p) == 2 and re.fullmatch(r"-?\d+", p[1]): out[p[0]] = int(p[1])
    return out
s = {"t": time.time(), "uptime": float(read("/proc/uptime").split()[0]), "loadavg": read("/proc/loadavg").split()[:3]}
stat = kv(read(os.path.join(group, "memory.stat")))
s["cg_stat"] = {k: v for k, v in stat.items() if k in ("pgmajfault", "pgpgin", "pgpgout", "pgfault", "total_pgmajfault", "total_pgpgin", "cache", "rss",
                                                         "mapped_file", "file", "anon", "file_mapped", "workingset_refault_file", "workingset_refault")}
if read(os.path.join(group, "memory.usage_in_bytes")) is not None:  # v1
    s["cg_usage"] = int(read(os.path.join(group, "memory.usage_in_bytes")))
    s["cg_peak"] = int(read(os.path.join(group, "memory.max_usage_in_bytes")))
    s["cg_failcnt"] = int(read(os.path.join(group, "memory.failcnt")))
    memsw = read(os.path.join(group, "memory.memsw.failcnt"))  # with memsw limited too, the charge fails there first
    if memsw is not None: s["cg_failcnt"] = max(s["cg_failcnt"], int(memsw))
    s["cg_limit"] = int(read(os.path.join(group, "memory.limit_in_bytes")))
    s["cg_oom_kill"] = kv(read(os.path.join(group, "memory.oom_control"))).get("oom_kill")
else:  # v2
    s["cg_usage"] = int(read(os.path.join(group, "memory.current")) or 0)
    peak = read(os.path.join(group, "memory.peak"))
    s["cg_peak"] = int(peak) if peak else None
    ev = kv(read(os.path.join(group, "memory.events")))
    s["cg_failcnt"] = ev.get("max")
    s["cg_oom_kill"] = ev.get("oom_kill")
    lim = (read(os.path.join(group, "memory.max")) or "max").strip()
    s["cg_limit"] = None if lim == "max" else int(lim)
io = kv((read("/proc/%s/io" % pid) or "").replace(":", ""))
s["proc_read_bytes"] = io.get("read_bytes")
st = read("/proc/%s/stat" % pid)
if st:
    f = st[st.rindex(")") + 2:].split()
    s["proc_majflt"] = int(f[9])   # field 12 (majflt): fields after the name start at field 3
status = kv((read("/proc/%s/status" % pid) or "").replace(" kB", "").replace(":", ""))
s["proc_rss_kb"], s["proc_hwm_kb"] = status.get("VmRSS"), status.get("VmHWM")
s["proc_rss_anon_kb"], s["proc_rss_file_kb"] = status.get("RssAnon"), status.get("RssFile")
try:
    m = urllib.request.urlopen("http://127.0.0.1:%s/metrics" % port, timeout=5).read().decode()
    cache = {}
    for name in ("hits_total", "misses_total", "evictions_total", "resident_bytes", "budget_bytes"):
        g = re.search(r"^tetrascope_cache_%s (\S+)" % name, m, re.M)
        if g: cache[name] = float(g.group(1))
    per = {}
    for name, ds, v in re.findall(r"^tetrascope_dataset_cache_(\w+)\{dataset=\"([^\"]*)\"\} (\S+)", m, re.M):
        per.setdefault(ds, {})[name] = float(v)
    s["cache"], s["cache_by_dataset"] = cache, per
except Exception as e:
    s["cache"], s["metrics_error"] = None, str(e)
print(json.dumps(s))
PY
}

# run KIND LIMIT N: one run; prints a JSON row
run() {
  local kind=$1 lim=$2 n=$3 drop j before after alive=1 exit_status="" started=1
  drop=$(drop_caches)
  local load_before
  load_before=$(cut -d' ' -f1-3 /proc/loadavg)
  start_server "$lim" "$n" || started=0
  local start_snap="{}"
  [[ -n "$server" ]] && start_snap=$(snapshot)
  before=$start_snap
  local url="ws://127.0.0.1:$port/api/v1/session"
  j=""
  if [[ $started == 1 ]]; then
    case $kind in
      orbit) j=$("$bin" loadtest --url "$url" --dataset "$name" --size 1024x768 --json --no-reconnect --duration "$duration" 2> "$out/runs/client-$n.err" | tail -1) || true ;;
      orbit-pause) j=$("$bin" loadtest --url "$url" --dataset "$name" --size 1024x768 --json --no-reconnect --duration $((duration + 12)) --path orbit-pause --orbit 3 --pause 6 2> "$out/runs/client-$n.err" | tail -1) || true ;;
      zoom) j=$(python3 "$zoom" --url "$url" --dataset "$name" --size 1024x768 --duration "$duration" 2> "$out/runs/client-$n.err" | tail -1) || true ;;
      zoom-pause) j=$(python3 "$zoom" --url "$url" --dataset "$name" --size 1024x768 --duration $((duration + 12)) --move 3 --pause 6 2> "$out/runs/client-$n.err" | tail -1) || true ;;
    esac
  fi
  after=$(snapshot)
  if ! alive "$server"; then
    alive=0
    set +e
    wait "$server" 2> /dev/null
    exit_status=$?
    set -e
  fi
  local oom_line
  oom_line=$(dmesg 2> /dev/null | grep -i "memory cgroup out of memory\|oom-kill" | grep -F "$tag-$n," | tail -2 | tr '\n' ' ' || true)
  cleanup
  python3 - "$kind" "$lim" "$n" "$drop" "$load_before" "$started" "$alive" "$exit_status" "$oom_line" "${j:-null}" "$start_snap" "$before" "$after" << 'PY'
import json, sys
kind, lim, n, drop, load_before, started, alive, exit_status, oom_line = sys.argv[1:10]
try:
    j = json.loads(sys.argv[10])
except ValueError:
    j = None
j = j or {}
if j.get("per_client") and j["per_client"][0].get("failure"):
    j["failure"] = j["per_client"][0]["failure"]
j.pop("per_client", None)
s0, b, a = (json.loads(x) for x in sys.argv[11:14])
secs = (a.get("t", 0) - b.get("t", 0)) or 1
def d(key, sub=None):
    x, y = (b.get(sub) or {}) if sub else b, (a.get(sub) or {}) if sub else a
    return (y.get(key) - x.get(key)) if x.get(key) is not None and y.get(key) is not None else None
def rate(v, scale=1):
    return None if v is None else v * scale / secs
ca, cb = a.get("cache") or {}, b.get("cache") or {}
hits = (ca.get("hits_total") or 0) - (cb.get("hits_total") or 0)
misses = (ca.get("misses_total") or 0) - (cb.get("misses_total") or 0)
page = 4096
row = {"run": kind, "limit_mb": None if lim == "none" else int(lim), "n": int(n), "page_cache": drop, "load_before": load_before,
       "load_during": a.get("loadavg"), "server_started": started == "1", "server_alive_after": alive == "1",
       "server_exit_status": int(exit_status) if exit_status else None, "oom_kernel_log": oom_line.strip() or None,
       "killed_after_s": None,  # from the client's start to the kernel's OOM kill (dmesg time)
       "loadtest": j,
       "cache": {"hits": hits, "misses": misses, "hit_rate": hits / (hits + misses) if hits + misses else None,
                 "evictions": (ca.get("evictions_total") or 0) - (cb.get("evictions_total") or 0),
                 "resident_mb_end": (ca.get("resident_bytes") or 0) / 1048576, "budget_mb": (ca.get("budget_bytes") or 0) / 1048576,
                 "by_dataset": a.get("cache_by_dataset")},
       "page_ins": {"seconds": secs,
                    "cg_pgmajfault": d("pgmajfault", "cg_stat"), "cg_pgmajfault_per_s": rate(d("pgmajfault", "cg_stat")),
                    "cg_pgpgin": d("pgpgin", "cg_stat"), "cg_pgpgin_per_s": rate(d("pgpgin", "cg_stat")),
                    "cg_workingset_refault_file": d("workingset_refault_file", "cg_stat"), "cg_workingset_refault_file_per_s": rate(d("workingset_refault_file", "cg_stat")),
                    "proc_majflt": d("proc_majflt"), "proc_majflt_per_s": rate(d("proc_majflt")),
                    "proc_read_mb": None if d("proc_read_bytes") is None else d("proc_read_bytes") / 1048576,
                    "proc_read_mb_per_s": rate(d("proc_read_bytes"), 1 / 1048576),
                    "server_start_read_mb": None if s0.get("proc_read_bytes") is None else s0["proc_read_bytes"] / 1048576},
       "memory": {"cg_limit_mb": None if (a.get("cg_limit") or b.get("cg_limit") or 1 << 60) >= 1 << 50 else (a.get("cg_limit") or b.get("cg_limit")) / 1048576,
                  "cg_peak_mb": (a.get("cg_peak") or b.get("cg_peak") or 0) / 1048576 or None, "cg_usage_mb_end": (a.get("cg_usage") or 0) / 1048576,
                  "cg_failcnt": a.get("cg_failcnt"), "cg_oom_kill": a.get("cg_oom_kill"),
                  "cg_cache_mb_end": (a.get("cg_stat") or {}).get("cache", (a.get("cg_stat") or {}).get("file", 0)) / 1048576,
                  "cg_rss_mb_end": (a.get("cg_stat") or {}).get("rss", (a.get("cg_stat") or {}).get("anon", 0)) / 1048576,
                  "proc_rss_mb_start": (s0.get("proc_rss_kb") or 0) / 1024, "proc_rss_mb_end": (a.get("proc_rss_kb") or 0) / 1024,
                  "proc_rss_anon_mb_end": (a.get("proc_rss_anon_kb") or 0) / 1024, "proc_rss_file_mb_end": (a.get("proc_rss_file_kb") or 0) / 1024,
                  "proc_hwm_mb": (a.get("proc_hwm_kb") or 0) / 1024}}
import re
g = re.search(r"^\[\s*([\d.]+)\]", oom_line.strip())
if g and b.get("uptime"):
    row["killed_after_s"] = float(g.group(1)) - b["uptime"]
row["completed"] = bool(j) and alive == "1" and j.get("frames", 0) > 0 and not j.get("failure") and j.get("errors", 1) == 0
if a.get("cache") is None:  # the server was gone: no /metrics at the end
    row["cache"] = {"hits": None, "misses": None, "hit_rate": None, "evictions": None, "resident_mb_end": None, "budget_mb": None, "by_dataset": None}
print(json.dumps(row))
PY
}

load_start=$(cut -d' ' -f1-3 /proc/loadavg)
limits=("$limit_mb")
[[ "$baseline" == 1 ]] && limits+=(none)
rows=()
n=0
for r in $(seq "$repeats"); do
  for lim in "${limits[@]}"; do
    for kind in $kinds; do
      n=$((n + 1))
      run "$kind" "$lim" "$n" > "$out/runs/row-$n.json"  # not in $(...): the server and group stay this shell's (trap)
      row=$(cat "$out/runs/row-$n.json")
      rows+=("$row")
      python3 -c "
import json,sys; r=json.loads(sys.argv[1]); l=r['loadtest']; p=r['page_ins']; c=r['cache']; m=r['memory']
res=l.get('resume_first_frame_ms') or {}
print('%-11s limit %-5s p50 %s p99 %s fps %s resume p50/p99 %s/%s | hit %s misses %s evict %s | majflt/s %s refault/s %s read MB/s %s | peak %s MB failcnt %s oom %s alive %s errors %s completed %s' % (
  r['run'], r['limit_mb'], '%.0f'%l['latency_ms']['p50'] if l else '-', '%.0f'%l['latency_ms']['p99'] if l else '-', '%.1f'%l['total_fps'] if l else '-',
  '%.0f'%res['p50'] if res else '-', '%.0f'%res['p99'] if res else '-', '%.3f'%c['hit_rate'] if c['hit_rate'] is not None else '-', c['misses'], c['evictions'],
  '%.0f'%p['proc_majflt_per_s'] if p['proc_majflt_per_s'] is not None else '-', '%.0f'%p['cg_workingset_refault_file_per_s'] if p['cg_workingset_refault_file_per_s'] is not None else '-', '%.1f'%p['proc_read_mb_per_s'] if p['proc_read_mb_per_s'] is not None else '-',
  '%.0f'%m['cg_peak_mb'] if m['cg_peak_mb'] else '-', m['cg_failcnt'], m['cg_oom_kill'], r['server_alive_after'], l.get('errors') if l else '-', r['completed']))
" "$row"
    done
  done
done
load_end=$(cut -d' ' -f1-3 /proc/loadavg)

mkdir -p "$(dirname "$out_json")"
python3 - "$out_json" "$store" "$limit_mb" "$cache_mb" "$frame_ms" "$duration" "$repeats" "$method" "$how" "$drop_note" "$load_start" "$load_end" "$workers" "$serve_opts" "${rows[@]}" << 'PY'
import json, os, sys, datetime, statistics
(out, store, limit_mb, cache_mb, frame_ms, duration, repeats, method, how, drop_note, load_start, load_end, workers, serve_opts), runs = sys.argv[1:15], [json.loads(r) for r in sys.argv[15:]]
def med(v):
    v = [x for x in v if x is not None]
    return statistics.median(v) if v else None
size = sum(os.path.getsize(os.path.join(store, f)) for f in os.listdir(store))
try:
    manifest = json.load(open(os.path.join(store, "manifest.json")))
    tets = manifest["counts"]["tetrahedra"]
except Exception:
    tets = None
summary = {}
for lim in sorted({r["limit_mb"] for r in runs}, key=lambda x: (x is None, x)):
    key = "limit_%d_mb" % lim if lim is not None else "no_limit"
    s = {}
    for kind in ("orbit", "zoom", "orbit-pause", "zoom-pause"):
        rs = [r for r in runs if r["limit_mb"] == lim and r["run"] == kind]
        if not rs:
            continue
        ok = [r for r in rs if r["completed"]]  # figures only from runs whose server lived and answered
        l = lambda f: med(f(r["loadtest"]) for r in ok)
        e = {"latency_p50_ms": l(lambda x: x["latency_ms"]["p50"]), "latency_p99_ms": l(lambda x: x["latency_ms"]["p99"]), "fps": l(lambda x: x["total_fps"]),
             "errors": sum((r["loadtest"] or {}).get("errors", 1) for r in rs), "runs_completed": len(ok)}
        if kind.endswith("pause"):
            e.update({"resume_first_frame_p50_ms": l(lambda x: x["resume_first_frame_ms"]["p50"]), "resume_first_frame_p99_ms": l(lambda x: x["resume_first_frame_ms"]["p99"]),
                      "release_to_still_p50_ms": l(lambda x: x["release_to_still_ms"]["p50"] if x["release_to_still_ms"]["samples"] else None),
                      "pauses_reaching_the_still": sum(r["loadtest"].get("pauses_reaching_the_still", 0) for r in ok), "pauses": sum(r["loadtest"].get("pauses", 0) for r in ok)})
        e.update({"cache_hit_rate": med(r["cache"]["hit_rate"] for r in rs), "cache_misses": med(r["cache"]["misses"] for r in rs),
                  "cache_evictions": med(r["cache"]["evictions"] for r in rs), "cache_resident_mb_end": med(r["cache"]["resident_mb_end"] for r in rs),
                  "cg_pgmajfault_per_s": med(r["page_ins"]["cg_pgmajfault_per_s"] for r in rs), "cg_pgpgin_per_s": med(r["page_ins"]["cg_pgpgin_per_s"] for r in rs),
                  "cg_refault_file_per_s": med(r["page_ins"]["cg_workingset_refault_file_per_s"] for r in rs), "proc_majflt_per_s": med(r["page_ins"]["proc_majflt_per_s"] for r in rs), "proc_read_mb_per_s": med(r["page_ins"]["proc_read_mb_per_s"] for r in rs),
                  "proc_read_mb": med(r["page_ins"]["proc_read_mb"] for r in rs), "server_start_read_mb": med(r["page_ins"]["server_start_read_mb"] for r in rs),
                  "cg_peak_mb": med(r["memory"]["cg_peak_mb"] for r in rs), "cg_failcnt": med(r["memory"]["cg_failcnt"] for r in rs),
                  "proc_rss_mb_end": med(r["memory"]["proc_rss_mb_end"] for r in rs), "proc_rss_anon_mb_end": med(r["memory"]["proc_rss_anon_mb_end"] for r in rs),
                  "oom_kills": sum(r["memory"]["cg_oom_kill"] or 0 for r in rs), "servers_lost": sum(not r["server_alive_after"] for r in rs),
                  "killed_after_s": med(r["killed_after_s"] for r in rs), "runs": len(rs)})
        s[kind] = e
    o, p = s.get("orbit"), s.get("orbit-pause")
    if o and p:
        s["goals"] = {"orbit_p50_le_100ms": o["latency_p50_ms"] is not None and o["latency_p50_ms"] <= 100, "orbit_fps_ge_20": o["fps"] is not None and o["fps"] >= 20,
                      "resume_p99_le_250ms": p["resume_first_frame_p99_ms"] is not None and p["resume_first_frame_p99_ms"] <= 250,
                      "zoom_p50_le_100ms": (s.get("zoom") or {}).get("latency_p50_ms") is not None and s["zoom"]["latency_p50_ms"] <= 100,
                      "zoom_resume_p99_le_250ms": (s.get("zoom-pause") or {}).get("resume_first_frame_p99_ms") is not None and s["zoom-pause"]["resume_first_frame_p99_ms"] <= 250}
    summary[key] = s
json.dump({"date": datetime.date.today().isoformat(),
           "machine": "%d cores shared with other work, Mesa llvmpipe, loopback; load average (1, 5, 15 min) at the start: %s, at the end: %s (per run: load_before, load_during)" % (os.cpu_count(), load_start, load_end),
           "store": store, "store_bytes": size, "store_mb": size / 1048576, "store_tetrahedra": tets,
           "limit_mb": int(limit_mb), "limit_method": method, "limit_how": how, "page_cache_before_each_run": drop_note,
           "server": ("tetrascope serve --workers %s --cache-mb %s --frame-ms %s %s" % (workers, cache_mb, frame_ms, serve_opts)).strip() + ", a fresh server and memory group per run",
           "clients": "1 client, 1024x768, 30 Hz: orbit (loadtest, %s s), zoom (bench/serve_memory_limit_zoom.py: to 0.2 of the distance and back every 8 s, a turn in 24 s; %s s), orbit-pause (loadtest --orbit 3 --pause 6, %s s), zoom-pause (the zoom moving 3 s, pausing 6 s, %s s)" % (duration, duration, int(duration) + 12, int(duration) + 12),
           "notes": "medians of the repeats; latency, fps and resume figures only from completed runs (the server alive at the end, frames received, no client error), the rest from all runs; page-ins per second of the run (from just before the client connects to its end). cg_pgpgin (cgroup v1) counts pages charged to the group (page cache and anonymous), not only disk reads; cg_pgmajfault and proc_majflt count faults that found the page outside the page cache (one per readahead window, so they undercount reads); cg_refault_file_per_s: file pages read again after the group's reclaim evicted them (thrashing); proc_read_mb is what the server caused to be read from the block device (read() and faults, with readahead). cg_peak_mb: the group's peak from server start to the run's end (page cache included). cache_*: the server's segment cache (/metrics), hit rate = hits / (hits + misses) during the run.",
           "repeats": int(repeats), "summary": summary, "runs": runs}, open(out, "w"), indent=1)
print(json.dumps(summary, indent=1))
PY
echo "$out_json written"
