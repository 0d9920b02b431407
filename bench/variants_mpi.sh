#!/usr/bin/env bash
# Segment variants under MPI: `mpirun -np 2 tetrascope preprocess --variants K`
# with a BEFORE binary (every rank received every variant) against this build (rank 0 alone
# receives them), RUNS alternated rounds; peak RSS and CPU seconds of each rank (each under
# its own /usr/bin/time) and the launch's wall time; the two stores compared byte for byte.
# Writes bench/results/variants_mpi.json.
#   BEFORE=/path/to/old/tetrascope bench/variants_mpi.sh [MESH (ONERA M6)]   RUNS=3 VARIANTS=3
set -euo pipefail
cd "$(dirname "$0")/.."
[[ -n "${BEFORE:-}" ]] || { echo "BEFORE=binary: the build to compare with"; exit 1; }
mesh="$(realpath "${1:-../shared/data/onera_m6_potential.vtk}")"
runs="${RUNS:-3}"
variants="${VARIANTS:-3}"
mpiexec="${MPIEXEC:-mpirun}"
command -v "$mpiexec" > /dev/null || { echo "$mpiexec is missing: scripts/install-deps installs Open MPI"; exit 1; }
[[ -x /usr/bin/time ]] || { echo "/usr/bin/time is missing: scripts/install-deps --bench installs it"; exit 1; }
cmake --build --preset release -j "$(nproc)" --target tetrascope > /dev/null
after=build/release/apps/tetrascope
# as root in a container (tests/mpi/preprocess_mpi_test.sh says why)
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl_vader_single_copy_mechanism=none OMPI_MCA_rmaps_base_oversubscribe=1
work="$(mktemp -d -t tetrascope-variants-mpi.XXXXXX)"
trap 'rm -rf "$work"' EXIT
rows="$work/rows.jsonl"
: > "$rows"

run() {  # BUILD BINARY RUN
  local build=$1 bin=$2 run=$3 store="$work/$1"
  rm -rf "$store" "$work"/rank.*
  cut -d' ' -f1 /proc/loadavg > "$work/load"
  /usr/bin/time -f "%M %e" -o "$work/all" "$mpiexec" -np 2 --bind-to none \
    sh -c 'exec /usr/bin/time -f "%M %e %U %S" -o "$0.${OMPI_COMM_WORLD_RANK:-$PMI_RANK}" "$@"' "$work/rank" \
    "$bin" preprocess "$mesh" -o "$store" --progress none --threads 1 --variants "$variants" > /dev/null
  python3 - "$build" "$run" "$work" >> "$rows" << 'PY'
import json, os, sys
build, run, work = sys.argv[1:4]
rss, cpu = [], []
for r in range(2):
    kb, _, user, system = open(os.path.join(work, f"rank.{r}")).read().split()
    rss.append(round(int(kb) / 1024, 1))
    cpu.append(round(float(user) + float(system), 2))
print(json.dumps({"build": build, "run": int(run), "load_before": float(open(os.path.join(work, "load")).read()),
                  "wall_seconds": float(open(os.path.join(work, "all")).read().split()[1]), "peak_rss_mb_per_rank": rss, "cpu_seconds_per_rank": cpu}))
PY
  tail -n 1 "$rows"
}

same=true
for r in $(seq "$runs"); do
  run before "$BEFORE" "$r"
  run after "$after" "$r"
  for f in segments.bin dag.bin manifest.json variants.bin; do cmp -s "$work/before/$f" "$work/after/$f" || same=false; done
done

python3 - "$rows" "$mesh" "$variants" "$same" "$BEFORE" > "$work/summary.json" << 'PY'
import json, os, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
def med(build, key, k=None):
    xs = [r[key] if k is None else r[key][k] for r in rows if r["build"] == build]
    return statistics.median(xs)
summary = {b: {"median_wall_seconds": med(b, "wall_seconds"), "median_peak_rss_mb_per_rank": [med(b, "peak_rss_mb_per_rank", k) for k in range(2)],
               "median_cpu_seconds_per_rank": [med(b, "cpu_seconds_per_rank", k) for k in range(2)]} for b in ("before", "after")}
print(json.dumps({"mesh": os.path.basename(sys.argv[2]), "variants": int(sys.argv[3]), "before_binary": sys.argv[5],
                  "command": "mpirun -np 2 --bind-to none tetrascope preprocess MESH -o STORE --threads 1 --variants K, each rank under /usr/bin/time",
                  "runs_per_build": len(rows) // 2, "same_store_bytes": sys.argv[4] == "true", "summary": summary, "runs": rows}, indent=2))
PY
mv "$work/summary.json" bench/results/variants_mpi.json
python3 -c 'import json; j=json.load(open("bench/results/variants_mpi.json")); print(j["same_store_bytes"], json.dumps(j["summary"]))'
