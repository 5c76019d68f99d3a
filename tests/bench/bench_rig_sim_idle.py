#!/usr/bin/env python3
"""First-reply latency of `piezo rig-sim` with 0, 300, 700 and 1,000 idle
TCP clients held open: connect, one read of 2 registers, the reply; 50
tries each, median and worst printed.

usage: bench_rig_sim_idle.py PIEZO SOURCE_DIR [PORT]
"""
import os
import resource
import socket
import statistics
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from peers import wait_for_tcp  # noqa: E402

READ = bytes([0, 1, 0, 0, 0, 6, 1, 3, 0, 0, 0, 2])


def main():
    piezo, source = sys.argv[1], sys.argv[2]
    port = int(sys.argv[3]) if len(sys.argv) > 3 else 5897
    hard = resource.getrlimit(resource.RLIMIT_NOFILE)[1]
    resource.setrlimit(resource.RLIMIT_NOFILE, (min(4096, hard), hard))
    rig = subprocess.Popen([piezo, "rig-sim", "--config",
                            os.path.join(source, "configs", "modbus-hil.toml"),
                            "--set", f"sensor.modbus.port={port}"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        if not wait_for_tcp(port):
            sys.exit("rig-sim did not start")
        for n in (0, 300, 700, 1000):
            idle = [socket.create_connection(("127.0.0.1", port)) for _ in range(n)]
            time.sleep(0.3)
            took = []
            for _ in range(50):
                t0 = time.perf_counter()
                s = socket.create_connection(("127.0.0.1", port))
                s.sendall(READ)
                s.recv(100)
                took.append((time.perf_counter() - t0) * 1e3)
                s.close()
            print(f"{n:5d} idle clients: first reply median {statistics.median(took):.2f} ms, "
                  f"worst {max(took):.2f} ms")
            for s in idle:
                s.close()
    finally:
        rig.kill()
        rig.wait()


if __name__ == "__main__":
    main()
