#!/usr/bin/env python3
"""Compressed segments: store size per input tet, decode speed and swap cost for
`preprocess --compress-segments none|index16|cutborder`, into bench/results/segment_compression.json.

  bench/segment_compression.py --bin build/release --stores DIR NAME=MESH [NAME=MESH ...]

Builds DIR/NAME.none, DIR/NAME.index16 and DIR/NAME.cutborder with `tetrascope preprocess`
(default options; kept if they exist), then runs segment_codec_bench pinned to one core
--runs times (default 3) and reports the median of each figure, with `uptime` before and after;
and cut_bench's swap rate (wall time, every segment mapped from a warm page cache) as often.
"""
import argparse
import json
import os
import statistics
import struct
import subprocess
import sys
import time

MODES = ["none", "index16", "cutborder"]


def uptime():
    return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()


def store_figures(path):
    """Bytes of the store's files, and its segments' connectivity stream bytes and tets."""
    files = {f: os.path.getsize(os.path.join(path, f)) for f in os.listdir(path)}
    manifest = json.load(open(os.path.join(path, "manifest.json")))
    data = open(os.path.join(path, "segments.bin"), "rb").read()
    segment_count = struct.unpack_from("<I", data, 40)[0]
    stream_bytes = tets = 0
    for i in range(segment_count):
        offset, _, _, _, tet_count = struct.unpack_from("<QQIII", data, 4096 + 72 * i)
        stream_bytes += struct.unpack_from("<12I", data, offset)[10]
        tets += tet_count
    return {
        "store_bytes": sum(files.values()),
        "segments_bin_bytes": files["segments.bin"],
        "input_tets": manifest["multiresolution"]["input"]["tetrahedra"],
        "stored_tets": tets,
        "segments": segment_count,
        "stream_bytes": stream_bytes,
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default="build/release")
    ap.add_argument("--stores", required=True)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--cpu", default="1", help="core the benchmark is pinned to")
    ap.add_argument("--out", default="bench/results/segment_compression.json")
    ap.add_argument("datasets", nargs="+")
    args = ap.parse_args()
    tetrascope = os.path.join(args.bin, "apps", "tetrascope")
    bench = os.path.join(args.bin, "bench", "segment_codec_bench")
    result = {"machine": os.uname().nodename, "cores": os.cpu_count(), "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
              "runs": args.runs, "statistic": "median of runs", "uptime_before": uptime(), "datasets": {}}
    for spec in args.datasets:
        name, mesh = spec.split("=", 1)
        entry = {"mesh": mesh, "modes": {}}
        for mode in MODES:
            path = os.path.join(args.stores, f"{name}.{mode}")
            if not os.path.exists(path):
                subprocess.run([tetrascope, "preprocess", mesh, "-o", path, "--compress-segments", mode, "--progress", "none"], check=True)
            f = store_figures(path)
            f["bytes_per_input_tet"] = f["store_bytes"] / f["input_tets"]
            f["segments_bin_bytes_per_stored_tet"] = f["segments_bin_bytes"] / f["stored_tets"]
            if mode == "cutborder":
                f["stream_bytes_per_stored_tet"] = f["stream_bytes"] / f["stored_tets"]
            entry["modes"][mode] = f
        runs = []
        for _ in range(args.runs):
            cmd = ["taskset", "-c", args.cpu, bench]
            for m in MODES:
                cmd += ["--store", f"{m}={os.path.join(args.stores, f'{name}.{m}')}"]
            out = subprocess.run(cmd + ["--benchmark_format=json", "--benchmark_min_time=0.5"], stdout=subprocess.PIPE, text=True, check=True).stdout
            runs.append({b["name"]: b for b in json.loads(out)["benchmarks"]})
        for mode in MODES:
            rates = []
            for _ in range(args.runs):
                out = subprocess.run(["taskset", "-c", args.cpu, os.path.join(args.bin, "bench", "cut_bench"), os.path.join(args.stores, f"{name}.{mode}")],
                                     stdout=subprocess.PIPE, text=True, check=True).stdout
                rates.append(json.loads(out)["swap"]["tets_per_second"] / 1e6)
            entry["modes"][mode]["cut_bench_swap_m_tets_per_second"] = {"median": statistics.median(rates), "runs": rates}
        for bench_name in runs[0]:
            kind, mode = bench_name.split("/")
            m = entry["modes"][mode]
            per_run_cpu = [r[bench_name]["cpu_time"] for r in runs]  # ms, one pass over every segment
            per_run_real = [r[bench_name]["real_time"] for r in runs]
            cpu_ms = statistics.median(per_run_cpu)
            m[kind] = {
                "ms_cpu_per_pass": cpu_ms,
                "ms_real_per_pass": statistics.median(per_run_real),
                "m_tets_per_cpu_second": m["stored_tets"] / cpu_ms / 1e3,
                "us_cpu_per_segment": cpu_ms * 1e3 / m["segments"],
                "runs_ms_cpu": per_run_cpu,
            }
        result["datasets"][name] = entry
        print(json.dumps({name: entry}, indent=1), file=sys.stderr)
    result["uptime_after"] = uptime()
    with open(args.out, "w") as f:
        json.dump(result, f, indent=2)
        f.write("\n")


if __name__ == "__main__":
    main()
