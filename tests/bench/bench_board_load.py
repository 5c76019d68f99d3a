#!/usr/bin/env python3
"""The drive loop's health on piezod's simulated rig under what a board meets
besides its run: nothing (the reference), a run started after IDLE seconds
of idle, and a watcher flooding fetch (300 x 30000 samples, never read)
during the run. Each case is a 1 s run by `piezo run --rig`; printed: drive
samples, missed deadlines and the worst period error.

usage: bench_board_load.py PIEZO PIEZOD SOURCE_DIR [IDLE_S] [PORT]
"""
import json
import os
import subprocess
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from peers import wait_for_tcp  # noqa: E402


def main():
    piezo, piezod, source = sys.argv[1:4]
    idle_s = float(sys.argv[4]) if len(sys.argv) > 4 else 30.0
    port = int(sys.argv[5]) if len(sys.argv) > 5 else 5893
    address = f"tcp://127.0.0.1:{port}"
    flood = os.path.join(source, "tests", "protocol", "fetch_flood.py")
    work = tempfile.mkdtemp(prefix="bench-board-load-")

    def run(label, during=None, before_s=0.0):
        board = subprocess.Popen([piezod, "--config",
                                  os.path.join(source, "configs", "piezod-sim.toml"),
                                  "--listen", address],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            if not wait_for_tcp(port):
                sys.exit("piezod did not start")
            time.sleep(before_s)
            side = threading.Thread(target=during) if during else None
            if side:
                threading.Timer(0.3, side.start).start()
            r = subprocess.run([piezo, "run", "--config", os.path.join(source, "configs", "sim.toml"),
                                "--rig", address, "--duration", "1", "--json", "--out",
                                os.path.join(work, label.replace(" ", "-"))],
                               capture_output=True, text=True, check=False)
            if side:
                time.sleep(0.1)
                side.join()
            d = json.loads(r.stdout)["drive"]
            print(f"{label:28s} drive samples {d['samples']:6d}  missed {d['missed_cycles']:6d}  "
                  f"worst period error {d['period_error_us']['max'] / 1e3:8.3f} ms", flush=True)
        finally:
            board.terminate()
            board.wait()

    run("reference")
    run(f"after {idle_s:g} s idle", before_s=idle_s)
    run("fetch flood from a watcher",
        during=lambda: subprocess.run(["/usr/bin/python3", flood, address, "300", "30000"],
                                      capture_output=True, check=False))


if __name__ == "__main__":
    main()
