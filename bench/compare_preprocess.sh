#!/usr/bin/env bash
# Before/after figures of a change to preprocess or the cut: `tetrascope preprocess` wall and
# CPU time (user + system: steadier than wall time on a shared machine), peak RSS, store size, `tetrascope verify`, and cut_bench (update time over a 100-step
# orbit, swap rate), RUNS times each, the two builds alternating so that load from other work
# on the machine falls on both alike. Medians go to OUT (JSON).
#   bench/compare_preprocess.sh BEFORE_DIR AFTER_DIR MESH OUT [RUNS]
# BEFORE_DIR and AFTER_DIR each hold a `tetrascope` and a `cut_bench` binary.
set -euo pipefail
before="$1"; after="$2"; mesh="$3"; out="$4"; runs="${5:-3}"
work="$(mktemp -d)"; trap 'rm -rf "$work"' EXIT
rows="$work/rows.jsonl"
for ((run = 1; run <= runs; ++run)); do
  for side in before after; do
    dir="${!side}"
    store="$work/$side.mt"
    /usr/bin/time -f "%M %e %U %S" -o "$work/time" "$dir/tetrascope" preprocess "$mesh" -o "$store" --force --progress none --json > "$work/report.json"
    verify=$("$dir/tetrascope" verify "$store" --progress none --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["ok"])')
    tets=$(python3 -c "import json; print(json.load(open('$work/report.json'))['input_tets'])")
    "$dir/cut_bench" "$store" --budget $(( tets / 5 )) --steps 100 > "$work/cut.json"
    (cd "$store" && sha256sum segments.bin dag.bin | awk '{print $1}' | sha256sum | cut -c1-16) > "$work/digest"
    python3 - "$side" "$run" "$work" "$verify" >> "$rows" <<'PY'
import json, sys
side, run, work, verify = sys.argv[1:5]
r = json.load(open(work + "/report.json"))
rss_kb, wall, user, system = open(work + "/time").read().split()
cut = json.load(open(work + "/cut.json"))
print(json.dumps({"side": side, "run": int(run), "wall_seconds": float(wall), "cpu_seconds": float(user) + float(system), "peak_rss_mb": int(rss_kb) / 1024,
                  "stage_seconds": r["stage_seconds"], "store_bytes": r["store_bytes"], "segments": r["segments"], "patches": r["patches"],
                  "verify_ok": verify == "True", "store_digest": open(work + "/digest").read().strip(),
                  "cut_update_ms_median": cut["update_ms"]["median"], "swap_tets_per_second": cut["swap"]["tets_per_second"], "cut": cut}))
PY
    tail -1 "$rows" | cut -c1-160
  done
done
python3 - "$rows" "$mesh" "$out" "$runs" <<'PY'
import json, statistics, sys, datetime, os
rows_path, mesh, out, runs = sys.argv[1:5]
rows = [json.loads(l) for l in open(rows_path)]
def summary(side):
    rs = [r for r in rows if r["side"] == side]
    med = lambda f: statistics.median(f(r) for r in rs)
    return {"wall_seconds": med(lambda r: r["wall_seconds"]), "cpu_seconds": med(lambda r: r["cpu_seconds"]), "peak_rss_mb": med(lambda r: r["peak_rss_mb"]),
            "simplify_seconds": med(lambda r: r["stage_seconds"]["simplify"]), "write_seconds": med(lambda r: r["stage_seconds"]["write"]),
            "read_seconds": med(lambda r: r["stage_seconds"]["read"]), "partition_seconds": med(lambda r: r["stage_seconds"]["partition"]),
            "cut_update_ms": med(lambda r: r["cut_update_ms_median"]), "swap_tets_per_second": med(lambda r: r["swap_tets_per_second"]),
            "store_bytes": rs[0]["store_bytes"], "segments": rs[0]["segments"], "patches": rs[0]["patches"],
            "verify_ok": all(r["verify_ok"] for r in rs), "store_digests": sorted({r["store_digest"] for r in rs})}
result = {"date": datetime.date.today().isoformat(), "mesh": os.path.basename(mesh), "runs_per_side": int(runs),
          "command": "tetrascope preprocess MESH (defaults) + verify; cut_bench --budget tets/5 --steps 100; before and after alternating",
          "medians": {"before": summary("before"), "after": summary("after")}, "runs": rows}
json.dump(result, open(out, "w"), indent=2)
for side in ("before", "after"):
    s = result["medians"][side]
    print(f"{side:6} wall {s['wall_seconds']:6.1f} s  cpu {s['cpu_seconds']:6.1f} s  simplify {s['simplify_seconds']:6.1f} s  write {s['write_seconds']:5.2f} s  RSS {s['peak_rss_mb']:6.0f} MB  "
          f"cut {s['cut_update_ms']:7.3f} ms  swap {s['swap_tets_per_second'] / 1e6:6.1f} Mt/s  verify {s['verify_ok']}  digests {s['store_digests']}")
PY
