#!/usr/bin/env python3
"""What the idle server holds in resident memory (it once held 1.0 GB with one 45K-tet dataset open
and no session, while the segment cache held 41 MB).

For --workers in WORKERS: starts `tetrascope serve`, reads /proc/PID/smaps at each step and sums
RSS by what maps it: heap (anonymous, incl. glibc arenas and llvmpipe's buffers), Mesa/LLVM code
and data (file-backed libraries), the stores' segments (mapped files under --data), stacks and the
rest. Steps: started; dataset opened (REST); after a 1-client loadtest of --seconds; then
--idle seconds later with no session. Writes bench/results/idle_memory.json.
  bench/idle_memory.py --store DIR/NAME [--workers 1,2,4] [--seconds 5] [--idle 12] [--label L]
"""
import argparse, json, os, re, shutil, signal, socket, subprocess, sys, tempfile, time, urllib.request

def free_port():
    s = socket.socket(); s.bind(("127.0.0.1", 0)); p = s.getsockname()[1]; s.close(); return p

def smaps(pid, data_dir):
    cats = {}
    current = None
    with open(f"/proc/{pid}/smaps") as f:
        for line in f:
            if re.match(r"^[0-9a-f]+-[0-9a-f]+ ", line):
                parts = line.split(None, 5)
                path = parts[5].strip() if len(parts) > 5 else ""
                if path.startswith(data_dir):
                    current = "store segments (mapped)"
                elif re.search(r"(LLVM|gallium|swrast|libGL|libEGL|mesa|dri)", path, re.I):
                    current = "Mesa/llvmpipe libraries"
                elif path == "[heap]" or path == "":
                    current = "anonymous (heap, arenas, llvmpipe buffers)"
                elif path.startswith("[stack"):
                    current = "stacks"
                elif path.startswith("/"):
                    current = "other libraries and files"
                else:
                    current = "other"
            elif line.startswith("Rss:"):
                cats[current] = cats.get(current, 0) + int(line.split()[1]) * 1024
    return {k: round(v / 2**20, 1) for k, v in sorted(cats.items())}

def rss_mb(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return round(int(line.split()[1]) / 1024, 1)

def threads(pid):
    return len(os.listdir(f"/proc/{pid}/task"))

def main():
    a = argparse.ArgumentParser()
    a.add_argument("--binary", default="build/release/apps/tetrascope")
    a.add_argument("--store", required=True)
    a.add_argument("--workers", default="1,2,4")
    a.add_argument("--seconds", type=int, default=5)
    a.add_argument("--idle", type=int, default=12)
    a.add_argument("--label", default="run")
    args = a.parse_args()
    name = os.path.basename(args.store.rstrip("/"))
    result = {"note": "2-core machine shared with other builds; one run per worker count", "dataset": name, "rows": []}
    for workers in [int(w) for w in args.workers.split(",")]:
        data = tempfile.mkdtemp(prefix="tetrascope-idle-")
        os.symlink(os.path.abspath(args.store), os.path.join(data, name))
        port = free_port()
        server = subprocess.Popen([args.binary, "serve", "--data", data, "--port", str(port), "--workers", str(workers)],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        base = f"http://127.0.0.1:{port}"
        try:
            for _ in range(100):
                try:
                    urllib.request.urlopen(base + "/api/v1/health", timeout=1).read(); break
                except OSError:
                    time.sleep(0.1)
            real = os.path.realpath(args.store)
            row = {"workers": workers, "steps": {}}
            def step(label):
                row["steps"][label] = {"rss_mb": rss_mb(server.pid), "threads": threads(server.pid), "by_mapping_mb": smaps(server.pid, real)}
            step("started")
            urllib.request.urlopen(base + f"/api/v1/datasets/{name}", timeout=120).read()
            step("dataset opened, no session yet")
            subprocess.run([args.binary, "loadtest", "--url", f"ws://127.0.0.1:{port}/api/v1/session", "--dataset", name,
                            "--clients", str(max(1, workers)), "--duration", str(args.seconds), "--size", "800x600"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
            step(f"right after {max(1, workers)} client(s) for {args.seconds} s")
            time.sleep(args.idle)
            step(f"{args.idle} s later, no session")
            print(json.dumps(row), flush=True)
            result["rows"].append(row)
        finally:
            server.send_signal(signal.SIGTERM)
            server.wait(timeout=30)
            shutil.rmtree(data, ignore_errors=True)
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results", "idle_memory.json")
    old = json.load(open(path)) if os.path.exists(path) else {}
    old[args.label] = result
    json.dump(old, open(path, "w"), indent=1)

if __name__ == "__main__":
    main()
