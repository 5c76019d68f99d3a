#!/usr/bin/python3
"""Bench: closed-loop moves (`piezo move`) against open-loop step counting
(`piezo step`) on the simulated rig, with a plant whose friction and piezo
coefficient differ from the model the controller predicts with. Prints a
table (figures, not assertions) and draws one move.

Usage: bench_moves.py PIEZO OUT_DIR [--modbus]
  --modbus also moves over Modbus TCP against `piezo rig-sim` (real time,
  the sensor at 1 kHz and at an RTU-like 200 Hz).
"""
import json
import math
import os
import shutil
import socket
import subprocess
import sys
import time

import h5py
import numpy as np

SOURCE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(SOURCE, "tests", "support"))
from peers import free_port  # noqa: E402

SIM = os.path.join(SOURCE, "configs", "sim.toml")
MODBUS = os.path.join(SOURCE, "configs", "modbus-hil.toml")
# The plant against the controller's model: mu +25 %, d_e -24 %, sigma0 +21 %.
MISMATCH = ["plant.mu=0.125", "plant.d_e=0.42e-6", "plant.sigma0=2000"]
NOISE_RAD = 0.5e-6 / 0.062  # the simulated sensor's noise, as an angle
TOLERANCE = 15e-6
F_HZ = 40.0


def piezo(exe, *args):
    out = subprocess.run([exe, *args], capture_output=True, text=True)
    if not out.stdout.strip():
        raise SystemExit(f"piezo {' '.join(args)} failed: {out.stderr}")
    return json.loads(out.stdout)


def sets(extra):
    return [a for s in extra for a in ("--set", s)]


def overshoot_rad(log, target):
    """How far the measured angle (averaged over 8 readings, as the
    controller sees it) went past the target (0 if never)."""
    with h5py.File(log) as f:
        theta = f["axes/rotor/sensor/theta"][:]
    theta = np.convolve(theta[np.isfinite(theta)], np.ones(8) / 8, mode="valid")
    beyond = (theta - target) * math.copysign(1.0, target)
    return max(0.0, float(beyond.max()))


def closed_loop(exe, out, target, config=SIM, extra=(), tag=""):
    run_dir = os.path.join(out, f"move{tag}_{target:+g}")
    m = piezo(exe, "move", "--to", repr(target), "--tolerance", repr(TOLERANCE), "--timeout",
              "60", "--f", repr(F_HZ), "--config", config, *sets(extra), "--json",
              "--out", run_dir)
    return m, overshoot_rad(m["log"], target) if m.get("log") else float("nan")


def open_loop(exe, out, target, step_rad):
    n = max(1, round(abs(target) / step_rad))
    args = ["step", str(n), "--f", repr(F_HZ), "--config", SIM, *sets(MISMATCH + ["run.clock=virtual"]),
            "--json", "--out", os.path.join(out, f"step_{target:+g}")]
    if target < 0:
        args.insert(2, "--reverse")
    r = piezo(exe, *args)
    return n, r["steps"]["travel_rad"] - target


def model_step(exe, reverse):
    args = ["simulate", "--set", f"f={F_HZ}", "--duration", repr(10 / F_HZ), "--json"]
    if reverse:
        args += ["--direction", "reverse"]
    return abs(piezo(exe, *args)["mean_velocity_rad_s"]) / F_HZ


def plot_move(log, target, png):
    with h5py.File(log) as f:
        ts, theta = f["axes/rotor/sensor/t"][:], f["axes/rotor/sensor/theta"][:]
        td, V, state = f["axes/rotor/drive/t"][:], f["axes/rotor/drive/V"][:], f["axes/rotor/drive/move_state"][:]
    base = png[:-4]
    np.savetxt(base + "_sensor.dat", np.column_stack([ts, 1e3 * theta]))
    np.savetxt(base + "_drive.dat", np.column_stack([td, V, state]))
    script = f"""
set terminal pngcairo size 900,800
set output '{png}'
set multiplot layout 3,1
set grid
set ylabel 'angle [mrad]'
plot '{base}_sensor.dat' using 1:2 with lines title 'measured', {1e3 * target} with lines dt 2 title 'target'
set ylabel 'drive [V]'
plot '{base}_drive.dat' using 1:2 with lines notitle
set ylabel 'phase'
set xlabel 't [s]'
set ytics ('coarse' 1, 'fine' 2, 'release' 3, 'settle' 4, 'on target' 5)
set yrange [0.5:5.5]
plot '{base}_drive.dat' using 1:3 with steps notitle
unset multiplot
"""
    subprocess.run(["gnuplot"], input=script, text=True, check=True)
    for suffix in ("_sensor.dat", "_drive.dat"):
        os.remove(base + suffix)


def modbus_moves(exe, out):
    print("\nOver Modbus TCP against piezo rig-sim (real time, paper-model plant):")
    print(f"{'sensor':>8} {'target':>9} | {'on target':>9} {'error':>9} {'time':>7} {'steps':>5}")
    for rate in (1000.0, 200.0):
        port = free_port()
        extra = [f"sensor.modbus.port={port}", f"drive.modbus-ao.port={port}", f"sensor.rate_hz={rate}"]
        sim = subprocess.Popen([exe, "rig-sim", "--config", MODBUS, *sets(extra), "--tcp",
                                f"127.0.0.1:{port}"], stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
        try:
            for _ in range(100):
                try:
                    socket.create_connection(("127.0.0.1", port), timeout=0.1).close()
                    break
                except OSError:
                    time.sleep(0.05)
            for target in (1e-3, -1e-3, 1e-2, -1e-2):
                m, _ = closed_loop(exe, out, target, MODBUS, extra, tag=f"_modbus{int(rate)}")
                print(f"{rate:6.0f}Hz {1e3 * target:+7.1f}mr | {str(m['on_target']):>9} "
                      f"{1e6 * (m['error_rad'] or float('nan')):7.1f}ur {m['time_s'] or 0:6.2f}s "
                      f"{m['steps'] or 0:5d}")
        finally:
            sim.terminate()
            sim.wait()


def main():
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    exe, out = sys.argv[1], sys.argv[2]
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    steps = {1: model_step(exe, False), -1: model_step(exe, True)}
    print(f"Simulated rig, virtual clock; plant {', '.join(MISMATCH)}; coarse steps at {F_HZ:g} Hz;")
    print(f"tolerance {1e6 * TOLERANCE:g} urad; sensor noise {1e6 * NOISE_RAD:.1f} urad "
          f"(3x: {3e6 * NOISE_RAD:.1f}); model step {1e3 * steps[1]:.3f} / {1e3 * steps[-1]:.3f} mrad")
    print(f"{'target':>9} | {'closed loop: error':>18} {'on target at':>12} {'overshoot':>10} "
          f"{'steps':>5} | {'open loop: steps':>16} {'error':>10}")
    for magnitude in (1e-4, 1e-3, 1e-2, 1e-1):
        for sign in (1, -1):
            target = sign * magnitude
            m, over = closed_loop(exe, out, target, SIM, MISMATCH + ["run.clock=virtual"])
            n, open_error = open_loop(exe, out, target, steps[sign])
            print(f"{1e3 * target:+7.1f}mr | {1e6 * m['error_rad']:16.1f}ur {m['time_s']:11.3f}s "
                  f"{1e6 * over:8.1f}ur {m['steps']:5d} | {n:16d} {1e3 * open_error:+8.3f}mr")
    plot_move(os.path.join(out, "move_+0.01", "run.h5"), 1e-2,
              os.path.join(out, "move.png"))
    print(f"\nplot of the +10 mrad move: {os.path.join(out, 'move.png')}")
    if "--modbus" in sys.argv:
        modbus_moves(exe, out)


if __name__ == "__main__":
    main()
