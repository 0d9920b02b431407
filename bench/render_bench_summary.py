#!/usr/bin/env python3
# Joins several bench/render_bench.sh outputs (repeated runs, or meshes run separately) into one
# results file: every run's rows as they were, and per mesh the median over the runs of each
# figure the rendering goals name, with the number of runs.
#   bench/render_bench_summary.py OUT.json RUN.json...
import json
import statistics
import sys

FIGURES = {
    "exact_ms": lambda r: r["dvr_exact"]["median_ms"],
    "exact_cpu_ms": lambda r: r["dvr_exact"]["median_cpu_ms"],
    "exact_draw_ms": lambda r: r["dvr_exact"]["median_draw_ms"],
    "projected_ms": lambda r: r["dvr"]["median_ms"],
    "projected_cpu_ms": lambda r: r["dvr"]["median_cpu_ms"],
    "projected_draw_ms": lambda r: r["dvr"]["median_draw_ms"],
    "iso_ms": lambda r: r["iso"]["median_ms"],
    "paraview_ms": lambda r: r["paraview_projected_tetra"]["median_ms"],
    "paraview_first_frame_ms": lambda r: r["paraview_projected_tetra"]["first_frame_ms"],
    "ceiling_exact_ms": lambda r: r["triangle_ceiling"]["exact"]["median_ms"],
    "ceiling_exact_cpu_ms": lambda r: r["triangle_ceiling"]["exact"]["median_cpu_ms"],
    "ceiling_projected_ms": lambda r: r["triangle_ceiling"]["projected"]["median_ms"],
    "ceiling_projected_cpu_ms": lambda r: r["triangle_ceiling"]["projected"]["median_cpu_ms"],
    "exact_speedup_vs_paraview": lambda r: r["exact_speedup_vs_paraview"],
    "projected_speedup_vs_paraview": lambda r: r["dvr_speedup_vs_paraview"],
    "exact_draw_vs_ceiling": lambda r: r["exact_draw_vs_ceiling"],
    "projected_draw_vs_ceiling": lambda r: r["projected_draw_vs_ceiling"],
    "exact_cpu_vs_ceiling_cpu": lambda r: r["exact_cpu_vs_ceiling_cpu"],
    "projected_cpu_vs_ceiling_cpu": lambda r: r["projected_cpu_vs_ceiling_cpu"],
}

out, paths = sys.argv[1], sys.argv[2:]
runs = [dict(json.load(open(p)), file=p) for p in paths]
meshes = {}
for run in runs:
    for row in run["runs"]:
        meshes.setdefault(row["mesh"], []).append(row)
summary = []
for mesh, rows in meshes.items():
    s = {"mesh": mesh, "tets": rows[0]["tets"], "runs": len(rows),
         "frames": sorted({row["dvr"]["frames"] for row in rows}),
         "ceiling_triangles": {"exact_rasterised": rows[0]["triangle_ceiling"]["exact"]["triangles_rasterised"],
                               "exact_culled": rows[0]["triangle_ceiling"]["exact"]["triangles_culled"],
                               "exact_mean_area_px": rows[0]["triangle_ceiling"]["exact"]["mean_area_px"],
                               "projected": rows[0]["triangle_ceiling"]["projected"]["triangles"],
                               "projected_mean_area_px": rows[0]["triangle_ceiling"]["projected"]["mean_area_px"]}}
    for name, get in FIGURES.items():
        s[name] = statistics.median(get(row) for row in rows)
    summary.append(s)
json.dump({"what": "bench/render_bench.sh runs joined by bench/render_bench_summary.py: per mesh the median over the runs of each run's median frame",
           "size": "1024x768", "machine": runs[0]["machine"],
           "loads": [{"file": r["file"], "meshes": [row["mesh"] for row in r["runs"]], "frames": r.get("frames"),
                      "load_average_before": r.get("load_average_before"), "load_average_after": r.get("load_average_after")} for r in runs],
           "summary": summary, "runs": runs}, open(out, "w"), indent=2)
print(f"{'mesh':24} {'tets':>9} {'runs':>4} | {'exact':>8} {'cpu':>7} {'proj':>8} {'cpu':>7} | {'PV':>8} | {'xPV e':>5} {'xPV p':>5} | "
      f"{'ceil e':>7} {'cpu':>6} {'ceil p':>7} {'cpu':>6} | {'e/ce':>5} {'p/ce':>5} {'cpu e':>5} {'cpu p':>5}")
for s in summary:
    print(f"{s['mesh']:24} {s['tets']:9} {s['runs']:4} | {s['exact_ms']:8.0f} {s['exact_cpu_ms']:7.0f} {s['projected_ms']:8.0f} {s['projected_cpu_ms']:7.0f} | "
          f"{s['paraview_ms']:8.0f} | {s['exact_speedup_vs_paraview']:5.2f} {s['projected_speedup_vs_paraview']:5.2f} | "
          f"{s['ceiling_exact_ms']:7.0f} {s['ceiling_exact_cpu_ms']:6.0f} {s['ceiling_projected_ms']:7.0f} {s['ceiling_projected_cpu_ms']:6.0f} | "
          f"{s['exact_draw_vs_ceiling']:5.2f} {s['projected_draw_vs_ceiling']:5.2f} {s['exact_cpu_vs_ceiling_cpu']:5.2f} {s['projected_cpu_vs_ceiling_cpu']:5.2f}")
