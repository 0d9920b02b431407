# A time series against ParaView 5.11, for bench/time_series_paraview.sh. Run with pvpython.
#   pvpython time_series_paraview.py CASE.foam STORE OUTDIR TETRASCOPE
#     for every time step of the OpenFOAM case (ParaView's reader's TimestepValues), the
#     store's step of that time (`tetrascope info --json` lists them) cut at full resolution
#     (`tetrascope cut --step K --budget 4000000000`: the input's vertices with that step's values)
#     against ParaView's reader at that time: tetrascope's vertex values against the
#     volume-weighted mean formed in numpy from ParaView's cell arrays (bench/cell_data_paraview.py's
#     check, at that time), points matched by coordinates. Prints one JSON line.
import json
import os
import subprocess
import sys

from paraview.simple import OpenFOAMReader

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cell_data_paraview import check  # noqa: E402


def main(case, store, out, tetrascope):
    reader = OpenFOAMReader(FileName=case)
    reader.UpdatePipelineInformation()
    times = list(reader.TimestepValues)
    info = json.loads(subprocess.run([tetrascope, "info", store, "--json"], check=True, capture_output=True, text=True).stdout)
    steps = info["time_steps"]["steps"]
    rows = []
    for t in times:
        step = min(steps, key=lambda s: abs(s["time"] - t))
        ours = os.path.join(out, "step_%d.vtk" % step["index"])
        subprocess.run([tetrascope, "cut", store, "--budget", "4000000000", "--step", str(step["index"]), "-o", ours], check=True, capture_output=True)
        r = check(case, ours, t)
        rows.append({"time": t, "step": step["index"], "step_time": step["time"], "points": r["points"], "points_matched": r["points_matched"],
                     "tetrascope_points": r["tetrascope_points"],
                     "arrays": [{"name": a["name"], "max_relative_difference": a.get("max_relative_difference")} for a in r["arrays"]]})
    worst = max((a["max_relative_difference"] for row in rows for a in row["arrays"] if a["max_relative_difference"] is not None), default=None)
    print(json.dumps({"case": os.path.basename(case), "paraview_steps": len(times), "store_steps": len(steps), "worst_max_relative_difference": worst, "steps": rows}))


if __name__ == "__main__":
    main(*sys.argv[1:5])
