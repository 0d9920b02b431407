#!/usr/bin/env bash
# The tetrascope half of bench/render_bench.sh (no ParaView and no gmsh here, so no blade
# meshes): `tetrascope render --orbit` frame times, DVR and isosurface at 1024x768, on shared
# datasets, RUNS runs each; prints one JSON object with every run and the median of the
# per-run medians. Used to compare two builds on a shared machine.
#   bench/render_shared_bench.sh TETRASCOPE_BINARY [RUNS] [FRAMES]
set -euo pipefail
cd "$(dirname "$0")/.."
binary=${1:?tetrascope binary}
runs=${2:-3}
frames=${3:-4}
data=../shared/data
mkdir -p bench/out
python3 - "$binary" "$runs" "$frames" "$data" <<'PY'
import json, statistics, subprocess, sys
binary, runs, frames, data = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
cases = [("disk_out_ref", "Temp"), ("nasa_bluntfin", "Density")]
out = {"binary": binary, "size": "1024x768", "frames_per_run": frames, "runs": runs, "meshes": []}
for mesh, attribute in cases:
    row = {"mesh": mesh, "attribute": attribute}
    for mode in ("dvr", "iso"):
        medians = []
        for run in range(runs):
            r = subprocess.run([binary, "render", f"{data}/{mesh}.vtk", "-o", f"bench/out/shared-{mesh}-{mode}.jpg", "--mode", mode,
                                "--attribute", attribute, "--size", "1024x768", "--orbit", str(frames), "--quality", "80", "--backend", "gl", "--json"],
                               check=True, capture_output=True, text=True)
            j = json.loads(r.stdout.strip().splitlines()[-1])
            medians.append({k: j[k] for k in ("median_ms", "median_sort_ms", "median_draw_ms", "median_readback_ms", "median_encode_ms")})
            row["tets"] = j["tets"]
        row[mode] = {"runs": medians, "median_ms": statistics.median(m["median_ms"] for m in medians),
                     "median_draw_ms": statistics.median(m["median_draw_ms"] for m in medians),
                     "median_sort_ms": statistics.median(m["median_sort_ms"] for m in medians)}
        print(mesh, mode, row[mode]["median_ms"], file=sys.stderr)
    out["meshes"].append(row)
print(json.dumps(out))
PY
