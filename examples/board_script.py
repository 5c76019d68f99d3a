#!/usr/bin/python3
"""A researcher's script on piezo_rig.board alone: a 2 s run on the board,
every sample kept (checked against the board's own count), then a
closed-loop move to 10 mrad, with where the rotor stopped measured at 0 V.

usage: board_script.py [ADDRESS]   (default tcp://127.0.0.1:5555; a board on
the network also needs keys=(board.pub, host.key), see docs/python.md)"""

import sys

import numpy as np

from piezo_rig.board import Board
from piezo_rig.errors import RunEnded

address = sys.argv[1] if len(sys.argv) > 1 else "tcp://127.0.0.1:5555"
with Board(address) as board:
    hello = board.hello()
    radii = ", ".join(f"{a['name']} r2 {a['r2_m']} m" for a in hello["axes"])
    print(f"board {hello['daemon']} at {address}: drive {hello['drive_rate_hz']:g} Hz, "
          f"sensor {hello['sensor_rate_hz']:g} Hz; axes: {radii}")
    if board.status()["state"] == "fault":
        board.reset_fault()

    with board.run(V0=60, f=10, duration=2) as run:
        for block in run:
            pass  # each block: numpy records, in sequence (gaps fetched)
    counted = run.summary["samples"]
    print(f"run {run.started['run']}: {run.summary['cause']}, drive {len(run.drive)} of "
          f"{counted['drive']} samples, sensor {len(run.sensor)} of {counted['sensor']}, "
          f"{run.gaps_fetched} fetched from the recorder, angle at the end "
          f"{1e3 * np.nanmean(run.theta()[-8:]):.3f} mrad")
    if (len(run.drive), len(run.sensor)) != (counted["drive"], counted["sensor"]):
        sys.exit("samples lost")

    try:
        move = board.move_to(0.010, tolerance_rad=50e-6)
    except RunEnded as e:
        sys.exit(f"the move ended {e.cause}")
    print(f"move to 10 mrad: on target at {move['on_target_at_s']:.2f} s after {move['steps']} "
          f"steps, position {1e3 * move['position_rad']:.4f} mrad "
          f"(error {1e6 * move['error_rad']:+.1f} urad)")
