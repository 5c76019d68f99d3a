#!/usr/bin/python3
"""Bench: what one live page costs on the wire. A real-time run on the
simulated rig (configs/sim.toml) with the view; READERS clients read
/api/live over HTTP as a browser's EventSource does (Accept-Encoding: gzip),
from the run's start, and as many again without compression. Prints the
bytes per second each reader received over the run's first 10 s and once
the 20 s window is full (from 25 s on). Figures, not assertions.

Usage: bench_view_bytes.py PIEZO [SECONDS] [READERS]
"""
import http.client
import json
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
import zlib

SOURCE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(SOURCE, "tests", "host"))
from view_browser_check import free_port  # noqa: E402


def read_stream(host, port, gzip, counts, stop):
    """Reads the event stream until `stop`; appends (t_s, bytes on the wire)
    per read, t_s the run time of the last event decoded."""
    conn = http.client.HTTPConnection(host, port, timeout=30)
    headers = {"Accept": "text/event-stream"}
    if gzip:
        headers["Accept-Encoding"] = "gzip, deflate"
    conn.request("GET", "/api/live", headers=headers)
    reply = conn.getresponse()
    inflate = zlib.decompressobj(16 + 15) if reply.getheader("Content-Encoding") == "gzip" else None
    buffer = b""
    t = 0.0
    while not stop.is_set():
        chunk = reply.read1(65536)
        if not chunk:
            break
        buffer += inflate.decompress(chunk) if inflate else chunk
        while b"\n\n" in buffer:
            event, buffer = buffer.split(b"\n\n", 1)
            try:
                t = json.loads(event.split(b"data: ", 1)[-1]).get("t_end", t)
            except ValueError:
                pass
        counts.append((t, len(chunk)))
    conn.close()


def main():
    piezo = sys.argv[1]
    seconds = float(sys.argv[2]) if len(sys.argv) > 2 else 40.0
    readers = int(sys.argv[3]) if len(sys.argv) > 3 else 1
    work = tempfile.mkdtemp(prefix="piezo-bench-view-bytes-")
    port = free_port()
    err_path = os.path.join(work, "err.txt")
    run = subprocess.Popen(
        [piezo, "run", "--config", os.path.join(SOURCE, "configs", "sim.toml"), "--duration",
         str(seconds), "--json", "--out", os.path.join(work, "run"), "--view", f"127.0.0.1:{port}"],
        stdout=subprocess.PIPE, stderr=open(err_path, "w"), text=True)
    deadline = time.time() + 30
    while time.time() < deadline and not re.search(r"live view: http://", open(err_path).read()):
        time.sleep(0.02)
    stop = threading.Event()
    ways = [True] * readers + [False] * readers
    counts = [[] for _ in ways]
    threads = [threading.Thread(target=read_stream, args=("127.0.0.1", port, gzip, c, stop),
                                daemon=True) for gzip, c in zip(ways, counts)]
    for t in threads:
        t.start()
    run.communicate()
    stop.set()
    print(f"{seconds:g} s run on configs/sim.toml, {readers} reader(s) of /api/live over HTTP "
          "each way")
    print(f"{'reader':>6} {'way':>13} {'reads':>6} {'first 10 s KiB/s':>17} {'window full KiB/s':>18}")
    for i, (gzip, c) in enumerate(zip(ways, counts)):
        first = sum(n for t, n in c if t <= 10.0) / 10.0
        late = [(t, n) for t, n in c if t >= 25.0]
        span = (late[-1][0] - late[0][0]) if len(late) > 1 else 0.0
        full = sum(n for _, n in late[1:]) / span if span > 0 else float("nan")
        way = "gzip" if gzip else "uncompressed"
        print(f"{i:>6} {way:>13} {len(c):>6} {first / 1024:>17.1f} {full / 1024:>18.1f}")


if __name__ == "__main__":
    main()
