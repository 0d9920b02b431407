#!/usr/bin/env bash
# Preprocessing on MPI: `tetrascope preprocess` alone against `mpirun -np 2
# tetrascope preprocess`, each with --threads 1 and with the default threads (one a core),
# RUNS runs each (interleaved, so that a busy spell on this shared machine falls on every
# configuration alike); wall time of the whole command, peak RSS and CPU seconds of each rank
# (every rank is its own process, /usr/bin/time around each), the load average before every
# run, rank 0's stage times; every store compared byte for byte with the first serial one, one MPI store
# run through verify. Stores go to a temporary folder, removed at the end.
# Writes bench/results/preprocess_mpi.json.
#   bench/preprocess_mpi.sh [MESH (/work/bigdata/blade-1m.vtk)]     RUNS=3 MPIEXEC=mpirun
#   bench/preprocess_mpi.sh --summarise RESULTS.json                 the summary again, from its runs
set -euo pipefail
cd "$(dirname "$0")/.."

summarise() {  # ROWS.jsonl MESH RUNS: the JSON on stdout
python3 - "$@" << 'PY'
import json, os, platform, statistics, subprocess, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
configs = {}
for row in rows:
    configs.setdefault(row["config"], []).append(row)
def median(xs): return statistics.median(xs)
summary = {}
for name, rs in configs.items():
    summary[name] = {"ranks": rs[0]["ranks"], "options": rs[0]["options"], "runs": len(rs),
                     "median_wall_seconds": median([r["wall_seconds"] for r in rs]),
                     "median_peak_rss_mb_per_rank": [median([r["peak_rss_mb_per_rank"][k] for r in rs]) for k in range(rs[0]["ranks"])],
                     "median_cpu_seconds_per_rank": [median([r["cpu_seconds_per_rank"][k] for r in rs]) for k in range(rs[0]["ranks"])],
                     "median_stage_seconds_rank0": {s: median([r["stage_seconds_rank0"][s] for r in rs]) for s in rs[0]["stage_seconds_rank0"]},
                     "all_same_bytes_as_serial": all(r["same_bytes_as_serial"] for r in rs)}
def speedup(serial, mpi): return round(summary[serial]["median_wall_seconds"] / summary[mpi]["median_wall_seconds"], 3)
# On a machine shared with other work the wall times say little: the kernel's autogroup
# scheduling shares the cores among sessions, so a second rank of the same session takes no
# more CPU than the first had. The CPU seconds of the busiest rank are what the launch needs
# of a core at least: serial CPU over that is the speed-up on an otherwise idle machine.
def cpu_speedup(serial, mpi): return round(summary[serial]["median_cpu_seconds_per_rank"][0] / max(summary[mpi]["median_cpu_seconds_per_rank"]), 3)
# each round runs the four configurations one after the other: its speed-ups, and the highest
# 1-minute load average seen before its runs (the quietest round says most about the code)
def rounds():
    out = []
    for run in sorted({r["run"] for r in rows}):
        wall = {r["config"]: r["wall_seconds"] for r in rows if r["run"] == run}
        out.append({"run": run, "max_load_before": max(r["load_before"][0] for r in rows if r["run"] == run),
                    "threads1": round(wall["serial-threads1"] / wall["mpi2-threads1"], 3), "default_threads": round(wall["serial"] / wall["mpi2"], 3)})
    return out
mpirun = subprocess.run(["mpirun", "--version"], capture_output=True, text=True).stdout.splitlines()[0]
print(json.dumps({
    "date": subprocess.run(["date", "-u", "+%Y-%m-%d"], capture_output=True, text=True).stdout.strip(),
    "machine": f"{os.cpu_count()} cores, {round(os.sysconf('SC_PAGE_SIZE') * os.sysconf('SC_PHYS_PAGES') / 2**30)} GB, shared with other work (see load_before)",
    "mesh": os.path.basename(sys.argv[2]), "mpi": mpirun,
    "command": "tetrascope preprocess MESH -o STORE --json [--threads 1] against mpirun -np 2 --bind-to none (the same, every rank under /usr/bin/time)",
    "speedup_2_ranks": {"threads1": speedup("serial-threads1", "mpi2-threads1"), "default_threads": speedup("serial", "mpi2")},
    "speedup_2_ranks_by_busiest_rank_cpu": {"threads1": cpu_speedup("serial-threads1", "mpi2-threads1")},
    "total_cpu_seconds": {name: round(sum(v["median_cpu_seconds_per_rank"]), 2) for name, v in summary.items()},
    "speedup_2_ranks_by_round": rounds(),
    "autogroup_scheduling": open("/proc/sys/kernel/sched_autogroup_enabled").read().strip() == "1",
    "summary": summary, "runs": rows}, indent=2))
PY
}

if [[ "${1:-}" == "--summarise" ]]; then
  rows="$(mktemp)"
  python3 -c 'import json, sys; [print(json.dumps(r)) for r in json.load(open(sys.argv[1]))["runs"]]' "$2" > "$rows"
  mesh=$(python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["mesh"])' "$2")
  summarise "$rows" "$mesh" 0 > "$2.new" && mv "$2.new" "$2"
  rm -f "$rows"
  exit 0
fi
mesh="$(realpath "${1:-/work/bigdata/blade-1m.vtk}")"
runs="${RUNS:-3}"
mpiexec="${MPIEXEC:-mpirun}"
bin=build/release/apps/tetrascope
command -v "$mpiexec" > /dev/null || { echo "$mpiexec is missing: scripts/install-deps installs Open MPI"; exit 1; }
[[ -x /usr/bin/time ]] || { echo "/usr/bin/time is missing: scripts/install-deps --bench installs it"; exit 1; }
cmake --preset release > /dev/null
cmake --build --preset release -j "$(nproc)" --target tetrascope > /dev/null
# as root in a container (tests/mpi/preprocess_mpi_test.sh says why)
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl_vader_single_copy_mechanism=none OMPI_MCA_rmaps_base_oversubscribe=1
work="$(mktemp -d -t tetrascope-mpi-bench.XXXXXX)"
trap 'rm -rf "$work"' EXIT
rows="$work/rows.jsonl"
: > "$rows"

run() {  # CONFIG RUN RANKS [THREADS OPTION...]
  local config=$1 run=$2 ranks=$3
  shift 3
  local store="$work/$config" load
  rm -rf "$store" "$work"/rank.*
  load=$(cut -d' ' -f1-3 /proc/loadavg)
  if ((ranks == 1)); then
    /usr/bin/time -f "%M %e %U %S" -o "$work/rank.0" $bin preprocess "$mesh" -o "$store" --progress none --json "$@" > "$work/report.json"
    cp "$work/rank.0" "$work/all"
  else
    # each rank under its own /usr/bin/time; the launch's wall time from the outer one
    # --bind-to none: Open MPI binds each of 2 ranks to one core, which would hold a rank's
    # threads on it and keep it off a core another program leaves idle
    /usr/bin/time -f "%M %e" -o "$work/all" "$mpiexec" -np "$ranks" --bind-to none \
      sh -c 'exec /usr/bin/time -f "%M %e %U %S" -o "$0.$OMPI_COMM_WORLD_RANK" "$@"' "$work/rank" \
      $bin preprocess "$mesh" -o "$store" --progress none --json "$@" > "$work/report.json"
  fi
  [[ -d "$work/reference" ]] || cp -r "$store" "$work/reference"
  local same=true
  for f in segments.bin dag.bin manifest.json; do cmp -s "$work/reference/$f" "$store/$f" || same=false; done
  local verify=skipped
  if ((ranks > 1 && run == 1)); then verify=$($bin verify "$store" --json | python3 -c 'import json,sys; print(str(json.load(sys.stdin)["ok"]).lower())'); fi
  python3 - "$config" "$run" "$ranks" "$load" "$same" "$verify" "$work" "$*" >> "$rows" << 'PY'
import glob, json, os, sys
config, run, ranks, load, same, verify, work, options = sys.argv[1:9]
wall = float(open(os.path.join(work, "all")).read().split()[1])
rss, cpu = [], []
for r in range(int(ranks)):
    kb, _, user, system = open(os.path.join(work, f"rank.{r}")).read().split()
    rss.append(round(int(kb) / 1024, 1))
    cpu.append(round(float(user) + float(system), 2))
report = json.load(open(os.path.join(work, "report.json")))
print(json.dumps({"config": config, "run": int(run), "ranks": int(ranks), "options": options, "load_before": [float(x) for x in load.split()],
                  "wall_seconds": wall, "peak_rss_mb_per_rank": rss, "cpu_seconds_per_rank": cpu, "stage_seconds_rank0": report["stage_seconds"],
                  "same_bytes_as_serial": same == "true", "verify_ok": None if verify == "skipped" else verify == "true",
                  "segments": report["segments"], "levels": len(report["levels"])}))
PY
  tail -n 1 "$rows"
}

for r in $(seq "$runs"); do
  run serial-threads1 "$r" 1 --threads 1
  run mpi2-threads1 "$r" 2 --threads 1
  run serial "$r" 1
  run mpi2 "$r" 2
done

summarise "$rows" "$mesh" "$runs" > bench/results/preprocess_mpi.json
cat bench/results/preprocess_mpi.json | python3 -c 'import json,sys; j=json.load(sys.stdin); print(j["speedup_2_ranks"]); print(j["speedup_2_ranks_by_busiest_rank_cpu"]); [print(k, v["median_wall_seconds"], v["median_peak_rss_mb_per_rank"], v["median_cpu_seconds_per_rank"]) for k, v in j["summary"].items()]'
