#!/usr/bin/env python3
"""The CPU ray caster and the GL renderer against the exact CPU integrator (render --reference)
on the shared datasets, from outside and from inside: per mesh the first broad or narrow view
of a fidelity_random.py record (of the seeds given) that shows at least 20% of its pixels, at
256x192; and thin opacity over long paths: onera_m6_potential through its symmetry plane (opacity
0.5 at both ends of the Cp range, 0 at Cp = 0) at unit distances 2, 0.5 and 0.05. Writes
bench/results/raycast_psnr.json.

    bench/raycast_psnr.py [SEED ...]   (default: 20261136 20261137)
"""
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BINARY = ROOT / "build" / "release" / "apps" / "tetrascope"
DATA = ROOT.parent / "shared" / "data"


def main():
    seeds = [int(s) for s in sys.argv[1:]] or [20261136, 20261137]
    records = json.loads((ROOT / "bench" / "results" / "fidelity_random.json").read_text())["records"]
    views = {}
    for record in records:
        if record["seed"] not in seeds:
            continue
        for c in record["cells"]:
            if c["kind"] != "iso" and c["coverage"] >= 0.2 and c["budget_pct"] == 5.0:
                views.setdefault((c["mesh"], c["inside"]), c)
    rows = []
    out = ROOT / "bench" / "out"
    out.mkdir(parents=True, exist_ok=True)
    for (mesh, inside), c in sorted(views.items()):
        tf = out / "raycast-psnr-tf.json"
        tf.write_text(json.dumps(c["tf"]))
        row = {"mesh": mesh, "eye": "inside" if inside else "outside", "camera": c["camera"], "tf": c["tf"]}
        for backend in ("gl", "cpu"):
            p = subprocess.run([str(BINARY), "render", str(DATA / mesh), "-o", str(out / f"raycast-psnr-{backend}.png"), "--camera", c["camera"], "--size", "256x192",
                                "--tf", str(tf), "--backend", backend, "--reference", "--json"], capture_output=True, text=True, check=True)
            row[backend + "_db"] = json.loads(p.stdout.strip().splitlines()[-1])["reference_psnr_db"]
        print(json.dumps({k: row[k] for k in ("mesh", "eye", "gl_db", "cpu_db")}), flush=True)
        rows.append(row)
    thin = []
    tf = out / "raycast-thin-tf.json"
    tf.write_text(json.dumps({"attribute": "pressure_coefficient", "colormap": "viridis", "range": [-0.718, 0.749], "opacity": [[-0.718, 0.5], [0, 0], [0.749, 0.5]]}))
    camera = "eye=0.5,-1.5,0,target=0.5,2,0,up=0,0,1,fov=50"
    for unit in (2, 0.5, 0.05):
        row = {"unit_distance": unit}
        for backend in ("gl", "cpu"):
            p = subprocess.run([str(BINARY), "render", str(DATA / "onera_m6_potential.vtk"), "-o", str(out / f"raycast-thin-{backend}.png"), "--camera", camera, "--size", "256x192",
                                "--tf", str(tf), "--unit-distance", str(unit), "--backend", backend, "--reference", "--json"], capture_output=True, text=True, check=True)
            row[backend + "_db"] = json.loads(p.stdout.strip().splitlines()[-1])["reference_psnr_db"]
        print(json.dumps(row), flush=True)
        thin.append(row)
    (ROOT / "bench" / "results" / "raycast_psnr.json").write_text(json.dumps({"seeds": seeds, "size": "256x192", "views": rows,
                                                                             "thin_opacity": {"mesh": "onera_m6_potential.vtk", "camera": camera, "rows": thin}}, indent=1))


if __name__ == "__main__":
    main()
