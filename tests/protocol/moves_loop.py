#!/usr/bin/python3
"""Fifty closed-loop moves in a row through piezod on the virtual clock,
with five times the default sensor noise and the host's observer on, as a
script of moves would run them (`piezo move --rig`): every one ends on
target, none `link_lost` (a host that still follows its move keeps its
lease however far the virtual board runs ahead). Prints each move and a
summary; exits non-zero on any other end.
usage: moves_loop.py PIEZO PIEZOD SOURCE_DIR"""
import json
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from peers import start_piezod  # noqa: E402

piezo, piezod, source = sys.argv[1:4]
work = tempfile.mkdtemp(prefix="moves-loop-")
with open(os.path.join(source, "configs", "piezod-sim.toml")) as f:
    board = f.read()
board = board.replace('clock = "realtime"', 'clock = "virtual"')
board = board.replace("noise_m = 0.5e-6", "noise_m = 2.5e-6")
assert 'clock = "virtual"' in board and "noise_m = 2.5e-6" in board
config = os.path.join(work, "board.toml")
with open(config, "w") as f:
    f.write(board)
daemon, address = start_piezod(piezod, config, os.path.join(work, "piezod.log"))
targets = [s * m for m in (0.3e-3, 3e-3, 30e-3, 1e-3, 10e-3) for s in (1, -1)] * 5
ends = {}
try:
    for i, target in enumerate(targets):
        out = subprocess.run([piezo, "move", "--rig", address, "--config",
                              os.path.join(source, "configs", "sim.toml"), "--to", repr(target),
                              "--timeout", "30", "--json", "--out", os.path.join(work, f"m{i}")],
                             capture_output=True, text=True, timeout=300)
        result = json.loads(out.stdout) if out.stdout.strip() else {"stop_cause": out.stderr}
        cause = result.get("stop_cause")
        ends[cause] = ends.get(cause, 0) + 1
        print(f"{i + 1:2d} {1e3 * target:+7.2f} mrad: {cause} in {result.get('time_s')} s",
              flush=True)
        if cause != "on_target":
            print(out.stderr)
            break
finally:
    daemon.terminate()
    daemon.wait()
print("ends:", ends)
sys.exit(0 if ends == {"on_target": len(targets)} else 1)
