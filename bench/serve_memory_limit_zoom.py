#!/usr/bin/env python3
"""A 1-client zoom load test for `tetrascope serve` (`tetrascope loadtest` has orbit, random
and orbit-pause paths, no zoom). Standard library only (a minimal WebSocket client).

The camera starts at the view a session opens with and, at --rate Hz, dollies towards the
target and back (distance factor 1 -> --near -> 1 every --period s, cosine) while turning
about the up axis once in --turn s, so each approach sees the dataset from another side and
the cut refines into other segments. With --pause S the path moves for --move s, stops for
--pause s (refinement runs), moves again, ... like `loadtest --path orbit-pause`.

Prints one JSON line with the fields `tetrascope loadtest --json` prints for one client
(latency as loadtest measures it: from a camera.set to the first frame whose header carries
its id; resume_first_frame_ms, release_to_first_refinement_ms, release_to_still_ms, pauses,
pauses_reaching_the_still when pausing).

  bench/serve_memory_limit_zoom.py --url ws://127.0.0.1:8080/api/v1/session --dataset blade20m \
      --size 1024x768 --duration 20 [--pause 6 --move 3]
"""
import argparse, base64, json, math, os, select, socket, struct, sys, time, urllib.parse, urllib.request

FRAME_HEADER_BYTES, FRAME_MAGIC = 48, 0x31465354


class WebSocket:
    def __init__(self, url):
        u = urllib.parse.urlparse(url)
        self.sock = socket.create_connection((u.hostname, u.port or 80), timeout=30)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall((f"GET {u.path or '/'} HTTP/1.1\r\nHost: {u.hostname}:{u.port}\r\nUpgrade: websocket\r\n"
                           f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n").encode())
        self.buf = b""
        while b"\r\n\r\n" not in self.buf:
            chunk = self.sock.recv(65536)
            if not chunk:
                raise RuntimeError("connection closed during the handshake")
            self.buf += chunk
        head, self.buf = self.buf.split(b"\r\n\r\n", 1)
        if b" 101 " not in head.split(b"\r\n", 1)[0]:
            raise RuntimeError("handshake refused: " + head.split(b"\r\n", 1)[0].decode(errors="replace"))
        self.sock.setblocking(False)
        self.next_id = 1
        self.partial, self.partial_op = b"", None

    def _send_frame(self, opcode, payload):
        n = len(payload)
        head = bytes([0x80 | opcode])
        head += bytes([0x80 | n]) if n < 126 else (bytes([0x80 | 126]) + struct.pack(">H", n) if n < 65536 else bytes([0x80 | 127]) + struct.pack(">Q", n))
        mask = os.urandom(4)
        masked = bytes(b ^ mask[i & 3] for i, b in enumerate(payload))
        data = head + mask + masked
        self.sock.setblocking(True)
        try:
            self.sock.sendall(data)
        finally:
            self.sock.setblocking(False)

    def send(self, type_, body):
        i = self.next_id
        self.next_id += 1
        body = dict(body, type=type_, id=i)
        self._send_frame(1, json.dumps(body).encode())
        return i

    def _parse(self):  # one complete frame from the buffer, or None
        b = self.buf
        if len(b) < 2:
            return None
        op, n, at = b[0] & 0x0F, b[1] & 0x7F, 2
        fin = b[0] & 0x80
        if n == 126:
            if len(b) < 4:
                return None
            n, at = struct.unpack(">H", b[2:4])[0], 4
        elif n == 127:
            if len(b) < 10:
                return None
            n, at = struct.unpack(">Q", b[2:10])[0], 10
        if b[1] & 0x80:
            at += 4  # servers do not mask; skip a mask if one came
        if len(b) < at + n:
            return None
        payload, self.buf = b[at:at + n], b[at + n:]
        return fin, op, payload

    def read(self, timeout):
        """(binary, bytes, received time) or None after timeout seconds."""
        deadline = time.monotonic() + max(0.0, timeout)
        while True:
            f = self._parse()
            while f:
                fin, op, payload = f
                if op == 9:
                    self._send_frame(10, payload)
                elif op == 8:
                    raise RuntimeError("closed by the server")
                elif op in (0, 1, 2):
                    if op:
                        self.partial_op, self.partial = op, payload
                    else:
                        self.partial += payload
                    if fin:
                        msg = (self.partial_op == 2, self.partial, time.monotonic())
                        self.partial = b""
                        return msg
                f = self._parse()
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            r, _, _ = select.select([self.sock], [], [], left)
            if r:
                chunk = self.sock.recv(1 << 20)
                if not chunk:
                    raise RuntimeError("connection closed")
                self.buf += chunk

    def expect(self, type_, timeout=60):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            m = self.read(deadline - time.monotonic())
            if m and not m[0]:
                j = json.loads(m[1])
                if j.get("type") == type_:
                    return j
                if j.get("type") == "error":
                    raise RuntimeError("server error: " + json.dumps(j))
        raise RuntimeError("no " + type_)


def percentile(v, p):  # as loadtest.cpp
    if not v:
        return 0.0
    v = sorted(v)
    at = p * (len(v) - 1)
    lo = int(math.floor(at))
    hi = min(len(v) - 1, lo + 1)
    return v[lo] + (v[hi] - v[lo]) * (at - lo)


def quantiles(v):
    return {"p50": percentile(v, 0.5), "p99": percentile(v, 0.99), "max": max(v) if v else 0.0, "samples": len(v)}


def rotate(v, k, a):  # Rodrigues, k normalised here
    n = math.sqrt(sum(x * x for x in k))
    k = [x / n for x in k]
    c, s = math.cos(a), math.sin(a)
    cr = [k[1] * v[2] - k[2] * v[1], k[2] * v[0] - k[0] * v[2], k[0] * v[1] - k[1] * v[0]]
    d = sum(k[i] * v[i] for i in range(3))
    return [v[i] * c + cr[i] * s + k[i] * d * (1 - c) for i in range(3)]


def health(url):
    u = urllib.parse.urlparse(url)
    try:
        with urllib.request.urlopen(f"http://{u.hostname}:{u.port}/api/v1/health", timeout=5) as r:
            return json.load(r)
    except Exception:
        return None


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--url", required=True)
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--size", default="1024x768")
    ap.add_argument("--duration", type=float, default=10)
    ap.add_argument("--rate", type=float, default=30)
    ap.add_argument("--near", type=float, default=0.2, help="closest distance, a fraction of the opening distance (0.2)")
    ap.add_argument("--period", type=float, default=8, help="seconds of moving from far to near and back (8)")
    ap.add_argument("--turn", type=float, default=24, help="seconds of moving for one turn about the up axis (24)")
    ap.add_argument("--pause", type=float, default=0, help="pause length, s (0: never pause)")
    ap.add_argument("--move", type=float, default=3, help="moving time between pauses, s (3)")
    o = ap.parse_args()
    width, height = (int(x) for x in o.size.split("x"))
    pausing = o.pause > 0
    r = {"frames": 0, "still": 0, "refining": 0, "errors": 0, "bytes": 0, "latency": [], "resume": [], "to_step": [], "to_still": [],
         "pauses": 0, "pauses_with_still": 0}
    before = health(o.url)
    failure = None
    start = time.monotonic()
    try:
        ws = WebSocket(o.url)
        ws.send("hello", {"version": 1, "token": ""})
        ws.expect("hello.ok")
        ws.send("view.resize", {"width": width, "height": height})
        ws.send("dataset.open", {"name": o.dataset})
        info = ws.expect("dataset.info")
        cam = info["camera"]
        eye, target, up, fov = cam["eye"], cam["target"], cam["up"], cam["fov"]
        offset = [eye[i] - target[i] for i in range(3)]
        start = time.monotonic()
        end = start + o.duration
        period = 1.0 / o.rate
        next_send, phase_end = start, start + o.move
        paused, resuming, resume_id = False, False, None
        released, saw_step, saw_still = 0.0, False, False
        sent = {}
        k = 0  # moves sent: the path's clock
        while time.monotonic() < end:
            now = time.monotonic()
            if pausing and now >= phase_end:
                paused = not paused
                phase_end += o.pause if paused else o.move
                if paused:
                    r["pauses"] += 1
                    released, saw_step, saw_still = now, False, False
                else:
                    next_send, resuming = now, True
            if not paused and now >= next_send:
                t = k / o.rate
                f = o.near + (1 - o.near) * (0.5 + 0.5 * math.cos(2 * math.pi * t / o.period))
                rotated = rotate(offset, up, 2 * math.pi * t / o.turn)
                e = [target[i] + rotated[i] * f for i in range(3)]
                i = ws.send("camera.set", {"eye": e, "target": target, "up": up, "fov": fov, "interacting": True})
                sent[i] = time.monotonic()
                if resuming:
                    resume_id = i
                resuming = False
                k += 1
                next_send += period
            wake = min(phase_end, end) if paused else min(next_send, end, phase_end if pausing else end)
            m = ws.read(max(0.001, wake - time.monotonic()))
            while m:
                binary, data, received = m
                if binary:
                    magic, version, codec, flags, number, mid = struct.unpack_from("<IHBBII", data, 0)
                    if magic != FRAME_MAGIC:
                        raise RuntimeError("frame: bad magic")
                    still, refining = bool(flags & 1), bool(flags & 2)
                    r["frames"] += 1
                    r["bytes"] += len(data)
                    if still:
                        r["still"] += 1
                    elif refining:
                        r["refining"] += 1
                    if pausing and paused and (still or refining):
                        since = (received - released) * 1000
                        if not saw_step:
                            r["to_step"].append(since)
                        saw_step = True
                        if still and not saw_still:
                            r["to_still"].append(since)
                            r["pauses_with_still"] += 1
                            saw_still = True
                    if resume_id is not None and mid >= resume_id and not still and not refining:
                        r["resume"].append((received - sent[resume_id]) * 1000)
                        resume_id = None
                    if mid in sent:
                        r["latency"].append((received - sent[mid]) * 1000)
                        for old in [x for x in sent if x <= mid]:
                            del sent[old]
                else:
                    j = json.loads(data)
                    if j.get("type") == "error":
                        r["errors"] += 1
                m = ws.read(0)
    except Exception as e:  # the server went away (OOM-killed?) or refused
        failure = str(e)
        r["errors"] += 1
    seconds = time.monotonic() - start
    after = health(o.url)
    lat = r["latency"]
    fps = r["frames"] / seconds if seconds > 0 else 0
    out = {"url": o.url, "dataset": o.dataset, "clients": 1, "duration_s": seconds, "path": "zoom-pause" if pausing else "zoom",
           "zoom": {"near": o.near, "period_s": o.period, "turn_s": o.turn}, "size": o.size, "frames": r["frames"], "total_fps": fps,
           "min_client_fps": fps, "max_client_fps": fps,
           "latency_ms": {"p50": percentile(lat, 0.5), "p95": percentile(lat, 0.95), "p99": percentile(lat, 0.99), "samples": len(lat)},
           "bytes_per_s": r["bytes"] / seconds if seconds > 0 else 0, "errors": r["errors"], "reconnects": 0,
           "clients_without_frames": int(r["frames"] == 0), "refining_frames": r["refining"], "failure": failure}
    if pausing:
        out.update({"resume_first_frame_ms": quantiles(r["resume"]), "release_to_first_refinement_ms": quantiles(r["to_step"]),
                    "release_to_still_ms": quantiles(r["to_still"]), "pauses": r["pauses"], "pauses_reaching_the_still": r["pauses_with_still"]})
    if before and after:
        out["server_rss_mb_before"] = before.get("rss_bytes", 0) / 1048576
        out["server_rss_mb_after"] = after.get("rss_bytes", 0) / 1048576
        out["server_peak_rss_mb"] = after.get("peak_rss_bytes", 0) / 1048576
    print(json.dumps(out))
    return 0 if r["errors"] == 0 and r["frames"] > 0 else 1


if __name__ == "__main__":
    sys.exit(main())
