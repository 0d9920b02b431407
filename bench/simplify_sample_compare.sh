#!/usr/bin/env bash
# The body of `bench/simplify_bench.sh --sample REPEATS` (see there).
# Environment: SAMPLE_DATASETS ("MESH:SCALAR ..."), BIN (the tetrascope binary), SEED (QEM's
# --seed, recorded in each row), SKIP_VTK=1 (no VTK decimation: it takes minutes a mesh),
# HELD_OUT ("NAME ..." meshes never looked at while tuning, marked in their rows),
# SKIP_QEM_DEFAULT=1 (no QEM run on the default threads: the goals compare one thread; the
# one-thread QEM's output is then the one judged).
set -euo pipefail
cd "$(dirname "$0")/.."
repeats=${1:-3}
bin=${BIN:-build/release/apps/tetrascope}
seed=${SEED:-1}
out=bench/out/simplify_sample
mkdir -p "$out" bench/results
datasets=${SAMPLE_DATASETS:-"../shared/data/onera_m6_potential.vtk:pressure_coefficient /work/bigdata/blade-1m.vtk:analytic_f /work/bigdata/blade-5m.vtk:analytic_f"}
rows=()
# one run: prints {"wall":..,"user":..,"report":{..}}
timed() {
  local log; log=$(mktemp)
  local json; json=$(/usr/bin/time -f '%e %U %M' -o "$log" "$@")
  python3 - "$log" "$json" <<'PY'
import json, sys
wall, user, rss = open(sys.argv[1]).read().split()[-3:]
print(json.dumps({"wall": float(wall), "user": float(user), "peak_rss_mb": int(rss) / 1024, "report": json.loads(sys.argv[2])}))
PY
  rm -f "$log"
}
for d in $datasets; do
  mesh=${d%%:*}; scalar=${d##*:}
  [[ -s "$mesh" ]] || { echo "skip $mesh (missing)"; continue; }
  name=$(basename "${mesh%.vtk}")
  runs_sample=(); runs_qem1=(); runs_qem=()
  for ((r = 0; r < repeats; ++r)); do
    runs_sample+=("$(timed $bin simplify "$mesh" -o "$out/$name.sample.vtk" --method sample --ratio 0.1 --json)")
    echo "${runs_sample[-1]}" | grep -q '"fell_back_to_qem": true' && echo "$name: the sampler fell back to QEM" >&2
    tets=$(echo "${runs_sample[-1]}" | python3 -c 'import json,sys; print(json.load(sys.stdin)["report"]["tets_after"])')
    runs_qem1+=("$(timed $bin simplify "$mesh" -o "$out/$name.qem1.vtk" --tets "$tets" --method qem --threads 1 --seed "$seed" --json)")
    if [[ -n "${SKIP_QEM_DEFAULT:-}" ]]; then
      runs_qem+=("${runs_qem1[-1]}"); cp "$out/$name.qem1.vtk" "$out/$name.qem.vtk"
    else
      runs_qem+=("$(timed $bin simplify "$mesh" -o "$out/$name.qem.vtk" --tets "$tets" --method qem --seed "$seed" --json)")
    fi
  done
  ratio=$(python3 -c "import json; r=json.loads('''${runs_sample[0]}''')['report']; print(r['tets_after']/r['tets_before'])")
  v=null
  [[ -n "${SKIP_VTK:-}" ]] || v=$(pvpython bench/vtk_decimate.py "$mesh" "$out/$name.vtk.vtk" "$ratio" "$scalar" 2>/dev/null | tail -1 || echo null)
  es=$($bin error "$mesh" "$out/$name.sample.vtk" --json)
  eq=$($bin error "$mesh" "$out/$name.qem.vtk" --json)
  ev=$( [[ "$v" != null && -s "$out/$name.vtk.vtk" ]] && $bin error "$mesh" "$out/$name.vtk.vtk" --json || echo null)
  is=$(pvpython bench/iso_compare.py "$mesh" "$out/$name.sample.vtk" "$scalar" 2>/dev/null | tail -1)
  iq=$(pvpython bench/iso_compare.py "$mesh" "$out/$name.qem.vtk" "$scalar" 2>/dev/null | tail -1)
  iv=$( [[ "$v" != null && -s "$out/$name.vtk.vtk" ]] && pvpython bench/iso_compare.py "$mesh" "$out/$name.vtk.vtk" "$scalar" 2>/dev/null | tail -1 || echo null)
  printf '%s\n' "${runs_sample[@]}" > "$out/$name.runs_sample.jsonl"
  printf '%s\n' "${runs_qem1[@]}" > "$out/$name.runs_qem1.jsonl"
  printf '%s\n' "${runs_qem[@]}" > "$out/$name.runs_qem.jsonl"
  rows+=("$(SEED=$seed python3 - "$name" "$scalar" "$out" "$v" "$es" "$eq" "$ev" "$is" "$iq" "$iv" <<'PY'
import json, os, statistics, sys
name, scalar, out, v, es, eq, ev, is_, iq, iv = sys.argv[1:11]
v, es, eq, ev, is_, iq, iv = map(json.loads, (v, es, eq, ev, is_, iq, iv))
def runs(kind):
    rs = [json.loads(l) for l in open(f"{out}/{name}.runs_{kind}.jsonl")]
    return {"runs": len(rs), "wall_median": statistics.median(r["wall"] for r in rs), "user_median": statistics.median(r["user"] for r in rs),
            "simplify_seconds_median": statistics.median(r["report"]["seconds"] for r in rs), "peak_rss_mb": max(r["peak_rss_mb"] for r in rs),
            "tets": rs[0]["report"]["tets_after"], "tets_before": rs[0]["report"]["tets_before"], "threads": rs[0]["report"]["threads"],
            "phases": rs[0]["report"].get("phase_seconds"), "fell_back_to_qem": rs[0]["report"].get("fell_back_to_qem")}
def err(e):
    if not e: return None
    return {"mean_field_error_all": e["mean_field_error"],
            "fields": {f["name"]: f["mean_field_error"] for f in e["fields"]},
            "hausdorff_relative": e["domain_error"]["hausdorff_relative"], "mean_distance_relative": e["domain_error"]["mean_relative"],
            "border_self_intersects": e["border_self_intersects"], "border_intersecting_pairs": e["border_intersecting_pairs"]}
s, q1, q = runs("sample"), runs("qem1"), runs("qem")
row = {"mesh": name, "scalar": scalar, "seed": int(os.environ["SEED"]), "held_out": name in os.environ.get("HELD_OUT", "").split(),
       "uptime": open("/proc/loadavg").read().split()[:3], "sample": dict(s, error=err(es), isosurfaces=is_["isosurfaces"]),
       "qem_one_thread": q1, "qem": dict(q, error=err(eq), isosurfaces=iq["isosurfaces"]),
       "vtk": dict(v, error=err(ev), isosurfaces=iv["isosurfaces"] if iv else None) if v else None,
       "speedup_user_vs_qem_one_thread": q1["user_median"] / s["user_median"],
       "speedup_simplify_seconds_vs_qem_one_thread": q1["simplify_seconds_median"] / s["simplify_seconds_median"],
       "speedup_wall_vs_qem_default": q["wall_median"] / s["wall_median"],
       "field_error_ratio": es["mean_field_error"] / max(eq["mean_field_error"], 1e-300),
       "fell_back_to_qem": s["fell_back_to_qem"]}
print(json.dumps(row))
PY
)")
  echo "${rows[-1]}" | cut -c1-200
done
python3 - "$repeats" "${rows[@]}" <<'PY'
import json, os, sys, datetime
repeats, rows = int(sys.argv[1]), [json.loads(r) for r in sys.argv[2:]]
for r in rows:
    r["repeats"] = repeats
path = "bench/results/simplify_sample.json"
if os.path.exists(path):  # rows of other datasets from earlier runs stay
    mine = {r["mesh"] for r in rows}
    rows = [r for r in json.load(open(path))["rows"] if r["mesh"] not in mine] + rows
machine = os.environ.get("BENCH_MACHINE", "2 cores shared with other builds and benchmarks: wall times are inflated; user CPU seconds are the steadier figure")
for r in rows:
    r.setdefault("machine", machine)
json.dump({"date": datetime.date.today().isoformat(), "machine": "per row (rows measured on different days and loads)",
           "note": "sample: simplify --method sample --ratio 0.1 (default thresholds, border error 0.2% of the diagonal), one thread; qem at the sample's tet count, --threads 1 and the default (both cores); VTK: vtkUnstructuredGridQuadricDecimation at the same ratio on the one scalar; errors by tetrascope error (all attributes; RMS normalised), isosurfaces by bench/iso_compare.py at 25/50/75% of the scalar's range (distances in % of the original isosurface's box diagonal)",
           "rows": rows}, open("bench/results/simplify_sample.json", "w"), indent=2)
for r in rows:
    s, q = r["sample"], r["qem"]
    print(f"{r['mesh']:22} tets {s['tets']:>8} | user s: sample {s['user_median']:.2f} qem1 {r['qem_one_thread']['user_median']:.2f} "
          f"x{r['speedup_user_vs_qem_one_thread']:.2f} | Ef sample {s['error']['mean_field_error_all']:.4f} qem {q['error']['mean_field_error_all']:.4f} | "
          f"Hd sample {100*s['error']['hausdorff_relative']:.3f}% qem {100*q['error']['hausdorff_relative']:.3f}% | self-int sample {s['error']['border_self_intersects']} qem {q['error']['border_self_intersects']}")
PY
