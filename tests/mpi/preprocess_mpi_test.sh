#!/usr/bin/env bash
# `mpirun -np 2 tetrascope preprocess` writes the same bytes as one process:
# segments.bin, dag.bin and manifest.json equal to the serial store's, which verify accepts;
# segments small enough that every level has several to share. With --variants
# variants.bin too: the ranks send a ceiling's variants to rank 0 alone. An error (the store exists,
# no --force) ends both ranks with the message, instead of leaving one waiting for the other.
#   tests/mpi/preprocess_mpi_test.sh TETRASCOPE_BINARY MPIEXEC SAMPLE_MESH
set -euo pipefail
bin="$(realpath "$1")"
mpiexec="$2"
mesh="$(realpath "$3")"
work="$(mktemp -d -t tetrascope-mpi-test.XXXXXX)"
trap 'rm -rf "$work"' EXIT
# CI runs as root in a container: Open MPI refuses root without these, and its shared-memory
# transport's single-copy mechanism (CMA) needs ptrace rights a container may not have
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl_vader_single_copy_mechanism=none
# a machine with one core still runs two ranks
export OMPI_MCA_rmaps_base_oversubscribe=1
options=(--segment-tets 1024 --base-tets 3000 --progress none)

"$bin" preprocess "$mesh" -o "$work/serial" "${options[@]}" --threads 1 > /dev/null
timeout 120 "$mpiexec" -np 2 "$bin" preprocess "$mesh" -o "$work/mpi" "${options[@]}" --json > "$work/mpi.json"
python3 - "$work/mpi.json" << 'PY'
import json, sys
report = json.loads(open(sys.argv[1]).read())  # rank 0 alone reports: one JSON document
levels = report["levels"]
assert len(levels) >= 3, levels
assert all(l["segments"] >= 2 for l in levels[:2]), f"levels 0 and 1 need several segments to share: {levels}"
PY
for f in segments.bin dag.bin manifest.json; do
  cmp "$work/serial/$f" "$work/mpi/$f" || { echo "FAIL: $f differs from the serial build's"; exit 1; }
done
"$bin" verify "$work/mpi" > /dev/null

"$bin" preprocess "$mesh" -o "$work/serial-variants" "${options[@]}" --threads 1 --variants 2 > /dev/null
timeout 120 "$mpiexec" -np 2 "$bin" preprocess "$mesh" -o "$work/mpi-variants" "${options[@]}" --variants 2 > /dev/null
[[ -s "$work/mpi-variants/variants.bin" ]] || { echo "FAIL: no variants.bin under mpirun"; exit 1; }
for f in segments.bin dag.bin manifest.json variants.bin; do
  cmp "$work/serial-variants/$f" "$work/mpi-variants/$f" || { echo "FAIL: $f (--variants 2) differs from the serial build's"; exit 1; }
done
"$bin" verify "$work/mpi-variants" > /dev/null

# an error on the ranks ends the launch with a message and a failing status
set +e
timeout 120 "$mpiexec" -np 2 "$bin" preprocess "$mesh" -o "$work/mpi" "${options[@]}" > "$work/again.log" 2>&1
status=$?
set -e
if ((status == 0 || status == 124)); then
  cat "$work/again.log"
  echo "FAIL: preprocess onto an existing store under mpirun ended with status $status"
  exit 1
fi
grep -q "exists (use --force to replace it)" "$work/again.log" || { cat "$work/again.log"; echo "FAIL: no message"; exit 1; }
echo "preprocess on 2 ranks: the same store as on one, with variants too"
