#!/usr/bin/env python3
"""What reading every axis at rest costs (docs/protocol.md, "At rest"):
piezod on the simulated rig on the real clock, with [piezod] idle_rate_hz
off, at its default and at ten times it. For each: piezod's CPU time over
IDLE seconds between runs, then a 2 s run by `piezo run --rig` after it
(the idle reader hands the sensors over at the run's start): the drive's
and the sensors' period error and missed deadlines, as the run's summary
gives them.

usage: bench_idle_reading.py PIEZO PIEZOD SOURCE_DIR [IDLE_S] [PORT]
"""
import json
import os
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from peers import wait_for_tcp  # noqa: E402


def cpu_s(pid):
    """User and system time of the process so far [s]."""
    fields = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def main():
    piezo, piezod, source = sys.argv[1:4]
    idle_s = float(sys.argv[4]) if len(sys.argv) > 4 else 10.0
    port = int(sys.argv[5]) if len(sys.argv) > 5 else 5897
    address = f"tcp://127.0.0.1:{port}"
    work = tempfile.mkdtemp(prefix="bench-idle-reading-")
    print(f"{'idle_rate_hz':>12s} {'idle CPU':>9s} {'drive p99/max':>16s} {'missed':>6s} "
          f"{'sensor p99/max':>16s} {'missed':>6s}")
    for rate in (0.0, 20.0, 200.0):
        board = subprocess.Popen([piezod, "--config",
                                  os.path.join(source, "configs", "piezod-sim.toml"),
                                  "--listen", address, "--set", f"piezod.idle_rate_hz={rate:g}"],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            if not wait_for_tcp(port):
                sys.exit("piezod did not start")
            time.sleep(1.0)
            before = cpu_s(board.pid)
            time.sleep(idle_s)
            idle_cpu = (cpu_s(board.pid) - before) / idle_s
            r = subprocess.run([piezo, "run", "--config", os.path.join(source, "configs", "sim.toml"),
                                "--rig", address, "--duration", "2", "--json", "--out",
                                os.path.join(work, f"rate-{rate:g}")],
                               capture_output=True, text=True, check=False)
            summary = json.loads(r.stdout)
            d, s = summary["drive"], summary["sensor"]
            print(f"{rate:12g} {100 * idle_cpu:8.2f}% "
                  f"{d['period_error_us']['p99']:7.0f}/{d['period_error_us']['max']:6.0f} us "
                  f"{d['missed_cycles']:6d} "
                  f"{s['period_error_us']['p99']:7.0f}/{s['period_error_us']['max']:6.0f} us "
                  f"{s['missed_cycles']:6d}", flush=True)
        finally:
            board.terminate()
            board.wait()


if __name__ == "__main__":
    main()
