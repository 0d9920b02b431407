#!/usr/bin/env bash
# Volume rendering with the camera inside each shared dataset: PSNR of `tetrascope render`
# (GL) against its own exact CPU integrator (`--reference`), one broad transfer function
# (opacity 0.05 at the attribute's minimum to 0.6 at its maximum). The eyes are tet centroids
# (so inside the mesh), found once with a nearest-centroid search. Both methods: `--volume
# exact` (the default; writes the reference image) and `--volume projected` (compared with
# that reference image through --compare).
#   bench/render_inside.sh TETRASCOPE_BINARY [WxH]    prints one JSON object
set -euo pipefail
cd "$(dirname "$0")/.."
binary=${1:?tetrascope binary}
size=${2:-192x144}
data=../shared/data
mkdir -p bench/out
python3 - "$binary" "$size" "$data" <<'PY'
import json, subprocess, sys, time
binary, size, data = sys.argv[1:4]
# dataset, attribute, camera (eye inside the mesh)
cases = [
    ("disk_out_ref", "Temp", "eye=2.12904,-1.92597,3.15248,target=0,0,0,up=0,0,1"),
    ("fea_bracket", "von_mises_stress_psi", "eye=-0.0675637,0.37571,1.08945,target=1.5,0.37571,1.08945,up=0,0,1"),
    ("freefem_leman", "potential", "eye=-0.20824,3.29907,-0.51048,target=20,3.29907,-0.51048,up=0,0,1"),
    ("nasa_bluntfin", "Density", "eye=-0.000572801,3.98972,2.69661,target=10,3.98972,2.69661,up=0,0,1"),
    ("nasa_combustion_chamber", "Density", "eye=7.90793,0.126204,26.007,target=7.90793,0.126204,36,up=1,0,0"),
    ("nasa_oxygen_post", "VelocityMagnitude", "eye=-8.30455,0.183817,2.36083,target=8,0.183817,2.36083,up=0,0,1"),
    ("onera_m6_potential", "pressure_coefficient", "eye=-0.473775,0.626537,0.32005,target=0.4,0.6,0,up=0,0,1"),
]
out = {"binary": binary, "size": size, "transfer_function": "opacity 0.05 at the minimum to 0.6 at the maximum, viridis", "meshes": []}
for mesh, attribute, camera in cases:
    path = f"{data}/{mesh}.vtk"
    info = json.loads(subprocess.run([binary, "info", "--json", path], check=True, capture_output=True, text=True).stdout)
    a = [x for x in info["attributes"] if x["name"] == attribute][0]
    tf = f"bench/out/inside-{mesh}-tf.json"
    json.dump({"attribute": attribute, "colormap": "viridis", "opacity": [[a["min"], 0.05], [a["max"], 0.6]]}, open(tf, "w"))
    start = time.time()
    r = subprocess.run([binary, "render", path, "-o", f"bench/out/inside-{mesh}.png", "--tf", tf, "--camera", camera, "--size", size,
                        "--volume", "exact", "--backend", "gl", "--reference", "--json"], check=True, capture_output=True, text=True)
    j = json.loads(r.stdout.strip().splitlines()[-1])
    seconds = round(time.time() - start, 1)
    r = subprocess.run([binary, "render", path, "-o", f"bench/out/inside-projected-{mesh}.png", "--tf", tf, "--camera", camera, "--size", size,
                        "--volume", "projected", "--compare", f"bench/out/inside-{mesh}.reference.png", "--json"], check=True, capture_output=True, text=True)
    p = json.loads(r.stdout.strip().splitlines()[-1])
    row = {"mesh": mesh, "tets": j["tets"], "attribute": attribute, "camera": camera, "psnr_db": round(j["reference_psnr_db"], 2),
           "psnr_db_projected": round(p["compare_psnr_db"], 2), "seconds_with_reference": seconds}
    print(json.dumps(row), file=sys.stderr)
    out["meshes"].append(row)
print(json.dumps(out))
PY
