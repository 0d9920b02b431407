#!/usr/bin/env bash
# Clip and slice planes on the 5M blade store at 1024x768 (Mesa llvmpipe): frame times (an
# 8-frame orbit, median) of DVR with one clip plane and one slice, next to plain DVR of the
# same budget in the same run; the one-off cost of a plane change (cut update, assembly, clip
# of the scene); and the PSNR of the slice alone (--mode slice) drawn from the cut at the
# still budget against the same slice of the whole mesh. RUNS repeats, medians; ORBIT frames
# an orbit (8).
# Writes bench/results/clip.json.
#   bench/clip_bench.sh [MESH] [RUNS]      (MESH: /work/bigdata/blade-5m.vtk)
set -euo pipefail
cd "$(dirname "$0")/.."
mesh="${1:-/work/bigdata/blade-5m.vtk}"; runs="${2:-3}"
bin=build/release/apps/tetrascope
store=bench/out/$(basename "$mesh" .vtk).mt
mkdir -p bench/out
[[ -d "$store" ]] || $bin preprocess "$mesh" -o "$store" --force --progress none > /dev/null
budget=500000  # the server's still budget
printf '{"attribute": "analytic_f", "colormap": "viridis", "opacity": [[-0.38, 0], [0.89, 0.4]]}\n' > bench/out/clip-tf.json
# the planes through the middle of the blade's box: clip x <= centre, slice z = centre
read -r cx cy cz < <($bin info "$store" --json | python3 -c 'import json,sys; b=json.load(sys.stdin)["bounds"]; print(*[(b["min"][k]+b["max"][k])/2 for k in range(3)])')
clip="1,0,0,$cx"; slice="0,0,1,$cz"
camera="azimuth=30,elevation=20"
rows=bench/out/clip-rows.jsonl; : > "$rows"
for ((run = 1; run <= runs; ++run)); do
  for variant in plain clip_slice; do
    planes=(); [[ $variant == clip_slice ]] && planes=(--clip "$clip" --slice "$slice")
    j=$($bin render "$store" --budget $budget --tf bench/out/clip-tf.json --size 1024x768 --camera "$camera" --orbit "${ORBIT:-8}" --quality 90 "${planes[@]}" -o bench/out/clip-$variant.jpg --json | tail -1)
    python3 -c "import json,sys; j=json.loads(sys.argv[1]); print(json.dumps({'run': $run, 'variant': '$variant', 'tets': j['tets'], 'median_ms': j['median_ms'], 'median_draw_ms': j['median_draw_ms'], 'update': j.get('update', {})}))" "$j" >> "$rows"
    tail -1 "$rows"
  done
  # the slice alone, from the cut and from the whole mesh
  $bin render "$store" --budget $budget --mode slice --slice "$slice" --tf bench/out/clip-tf.json --size 1024x768 --camera "$camera" -o bench/out/slice-cut.png --json > bench/out/slice-cut.json
  $bin render "$mesh" --mode slice --slice "$slice" --tf bench/out/clip-tf.json --size 1024x768 --camera "$camera" -o bench/out/slice-full.png --json > bench/out/slice-full.json
  db=$(/usr/bin/python3 bench/psnr.py bench/out/slice-cut.png bench/out/slice-full.png | grep -o '[0-9.]*' | head -1)
  python3 -c "import json; c=json.load(open('bench/out/slice-cut.json')); print(json.dumps({'run': $run, 'variant': 'slice_psnr', 'psnr_db': float('$db'), 'cut_tets': c['tets'], 'full_tets': json.load(open('bench/out/slice-full.json'))['tets']}))" >> "$rows"
  tail -1 "$rows"
done
python3 - "$rows" "$mesh" "$runs" "$clip" "$slice" <<'PY'
import json, statistics, sys, datetime, os
rows_path, mesh, runs, clip, slice_ = sys.argv[1:6]
rows = [json.loads(l) for l in open(rows_path)]
med = lambda v, f: statistics.median(f(r) for r in rows if r["variant"] == v)
plain, planes = med("plain", lambda r: r["median_ms"]), med("clip_slice", lambda r: r["median_ms"])
result = {"date": datetime.date.today().isoformat(), "machine": "2 cores shared with other builds, Mesa llvmpipe", "mesh": os.path.basename(mesh),
          "runs": int(runs), "orbit_frames": int(os.environ.get("ORBIT", "8")), "size": "1024x768", "budget": 500000, "clip": clip, "slice": slice_,
          "frame_ms": {"plain_dvr": plain, "dvr_clip_slice": planes, "ratio": planes / plain},
          "tets_drawn": {"plain_dvr": med("plain", lambda r: r["tets"]), "dvr_clip_slice": med("clip_slice", lambda r: r["tets"])},
          "plane_change_ms": {k: med("clip_slice", lambda r, k=k: r["update"].get(k, 0)) for k in ("cut_ms", "assemble_ms", "clip_ms")},
          "slice_psnr_db": med("slice_psnr", lambda r: r["psnr_db"]),
          "slice_cut_tets": med("slice_psnr", lambda r: r["cut_tets"]), "rows": rows}
json.dump(result, open("bench/results/clip.json", "w"), indent=2)
print(json.dumps({k: result[k] for k in ("frame_ms", "tets_drawn", "plane_change_ms", "slice_psnr_db")}, indent=1))
PY
