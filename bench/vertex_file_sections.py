#!/usr/bin/env python3
"""What each section of a store's vertices.bin takes on disk, per update (collapse).

    bench/vertex_file_sections.py STORE [STORE ...] [--json OUT]

Reads the header of vertices.bin (version 1 or 2, docs/store-format.md) and prints, per store,
the stored bytes of every section and per collapse, the split information (version 2: the
children, the after counts and the after links; version 1: the children and fans, the killers,
both link lists and their offsets) and the store's bytes with and without the file. With
--json, adds one record {date, stores: [...]} to OUT (a file of {"records": [...]}).
"""
import datetime
import json
import os
import struct
import sys

NAMES = {
    1: ["attributes", "positions", "values", "tets", "killer", "nodes", "ranges", "after offsets", "after", "before offsets", "before"],
    2: ["attributes", "positions", "values", "tets", "children", "error and radius", "ranges", "after counts", "after"],
}
SPLIT = {1: ["killer", "nodes", "after offsets", "after", "before offsets", "before"], 2: ["children", "after counts", "after"]}


def sections(path):
    with open(path, "rb") as f:
        head = f.read(4096)
    if head[:8] != b"TSVERTH1":
        raise SystemExit(f"{path}: not a vertices.bin")
    version, V, C, A, F, S = struct.unpack_from("<6I", head, 8)
    T = struct.unpack_from("<Q", head, 32)[0]
    at, flags, out = 40, 0, {}
    if version == 2:
        flags = struct.unpack_from("<I", head, 40)[0]
        at = 44
    for name in NAMES[version]:
        if version == 1:
            _, stored, _ = struct.unpack_from("<QQI", head, at)
            at += 20
        else:
            _, stored, _, _, _ = struct.unpack_from("<QQQII", head, at)
            at += 32
        out[name] = stored
    return {"version": version, "flags": flags, "input_vertices": V, "collapses": C, "attributes": A, "value_floats": F, "input_tets": T, "sections": out}


def describe(store):
    path = os.path.join(store, "vertices.bin")
    info = sections(path)
    C = max(1, info["collapses"])
    total = sum(os.path.getsize(os.path.join(store, f)) for f in os.listdir(store) if os.path.isfile(os.path.join(store, f)))
    file_bytes = os.path.getsize(path)
    split = sum(info["sections"][n] for n in SPLIT[info["version"]])
    info.update({
        "store": os.path.basename(os.path.normpath(store)),
        "file_bytes": file_bytes,
        "file_bytes_per_update": file_bytes / C,
        "split_information_bytes_per_update": split / C,
        "section_bytes_per_update": {n: b / C for n, b in info["sections"].items()},
        "store_bytes": total,
        "store_bytes_without": total - file_bytes,
        "size_over_without": total / (total - file_bytes) - 1,
    })
    return info


def main(argv):
    out = None
    if "--json" in argv:
        i = argv.index("--json")
        out = argv[i + 1]
        del argv[i:i + 2]
    rows = [describe(s) for s in argv]
    for r in rows:
        per = ", ".join(f"{n} {b:.1f}" for n, b in r["section_bytes_per_update"].items())
        print(f"{r['store']}: version {r['version']} flags {r['flags']}, {r['file_bytes']:,} bytes ({r['file_bytes_per_update']:.1f} an update; split information {r['split_information_bytes_per_update']:.1f}); "
              f"store {r['store_bytes']:,} bytes, +{100 * r['size_over_without']:.1f}% over {r['store_bytes_without']:,} without; per update: {per}")
    if out:
        old = json.load(open(out)) if os.path.exists(out) else {"records": []}
        old["records"].append({"date": datetime.date.today().isoformat(), "stores": rows})
        json.dump(old, open(out, "w"), indent=1)


if __name__ == "__main__":
    main(sys.argv[1:])
