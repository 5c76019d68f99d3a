#!/usr/bin/env python3
"""Fly scans (docs/scans.md) on the simulated rig in real time: piezod on
configs/piezod-sim.toml (one axis), calibrated first. Prints, from the
board's own account of each scan:
- the time from the reading whose filtered angle crossed a position to
  that pulse's edge (p50, p99, max), over every pulse of every scan;
- the velocity over the span and its ripple against the velocity asked,
  at five velocities across the axis's range;
- the highest trigger rate held with no late pulse: at the top velocity,
  trigger steps from ten times the noise rule's smallest down to it; then,
  on a board whose sensor has a twenty-fifth of the noise (so the rule
  admits steps shorter than one reading's travel), down past one reading's
  travel, where positions start to share a reading and come late.

With GPIO_GUEST_WORK (the gpio-sim scan's guest directory, after `ctest
-R gpio_sim_scan` ran it: tests/gpio-sim/test_gpio_scan.py), the same
reading-to-edge figures from that scan's log, on the gpio-sim chip in the
emulated guest, and when the guest's own watcher saw each edge after it.

usage: bench_scans.py PIEZOD SOURCE_DIR [PORT] [GPIO_GUEST_WORK]
"""
import os
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from peers import wait_for_tcp  # noqa: E402


def board(piezod, source, port, work, *sets):
    process = subprocess.Popen(
        [piezod, "--config", os.path.join(source, "configs", "piezod-sim.toml"), "--listen",
         f"tcp://127.0.0.1:{port}", "--set", f"piezod.calibration_file={work}/calibration.json",
         *[a for s in sets for a in ("--set", s)]],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    if not wait_for_tcp(port):
        sys.exit("piezod did not start")
    return process, f"tcp://127.0.0.1:{port}"


def scan(b, start, span, v, step, width=2e-4):
    with b.scan(start, start + span, v, trigger_step_rad=step, trigger_width_s=width) as s:
        s.wait()
    account = s.accounts[s.axis]
    return account, s.pulses()


def gpio_sim(source, work):
    """The gpio-sim guest's scan: reading to edge from its log, and the
    chip's edges as its watcher saw them."""
    import io
    import h5py
    sys.path.insert(0, os.path.join(source, "tests", "gpio-sim"))
    from test_gpio_scan import guest_output
    out = guest_output(work)
    with h5py.File(io.BytesIO(out["log"])) as f:
        t = f["axes/rotor/triggers"]
        order = np.argsort(t["k"][()])
        lat = 1e3 * (t["edge_s"][()] - t["reading_s"][()])[order]
        edge_s = t["edge_s"][()][order]
        t0 = int(f.attrs["board_t0_ns"])
    seen = np.array([int(x) for x in out["edges"].decode().split()])
    lag = (seen - (t0 + np.round(edge_s * 1e9))) / 1e6
    print(f"gpio-sim guest (2 kHz drive, 500 Hz sensor, emulated): reading to edge p50 "
          f"{np.percentile(lat, 50):.3f} ms, p99 {np.percentile(lat, 99):.3f} ms over {len(lat)} "
          f"pulses; the chip's edge seen by the watcher {np.percentile(lag, 50):.2f} ms (p50), "
          f"{lag.max():.2f} ms (max) after the logged edge")


def main():
    from piezo_rig.board import Board
    piezod, source = sys.argv[1:3]
    port = int(sys.argv[3]) if len(sys.argv) > 3 else 5911
    if len(sys.argv) > 4:
        gpio_sim(source, sys.argv[4])
    work = tempfile.mkdtemp(prefix="bench-scans-")
    process, address = board(piezod, source, port, work)
    latencies = []
    try:
        with Board(address) as b:
            b.calibrate(progress=False)
            info = b.hello()["axes"][0]
            base, top = info["base_rate_rad_per_s"], info["velocity_max_rad_per_s"]
            print(f"axis {info['name']}: base rate {base:.4g} rad/s, highest steady velocity "
                  f"{top:.4g} rad/s; sensor {b.hello()['sensor_rate_hz']:g} Hz")
            print(f"{'v [rad/s]':>10s} {'measured':>9s} {'error':>7s} {'ripple/period':>13s} "
                  f"{'ripple/10':>9s} {'model':>8s} {'f [Hz]':>7s} {'pulses':>6s} {'late':>4s}")
            where = 0.0
            for share in (0.1, 0.3, 0.5, 0.7, 0.9):
                v = base + share * (top - base)
                span = max(0.02, 2.0 * v)  # at least two seconds of span
                account, pulses = scan(b, where, span, v, 0.002)
                where += span
                latencies += [p.edge_s - p.reading_s for p in pulses]
                m = account["measured_velocity_rad_per_s"]
                print(f"{v:10.4g} {m:9.4g} {100 * (m / v - 1):+6.2f}% "
                      f"{100 * account['ripple_rad_per_s'] / v:12.2f}% "
                      f"{100 * account['ripple_10_rad_per_s'] / v:8.2f}% "
                      f"{account['model_velocity_rad_per_s']:8.4g} {account['mean_f_hz']:7.3g} "
                      f"{account['triggers']['fired']:6d} {account['triggers']['late']:4d}")
            lat = 1e3 * np.array(latencies)
            print(f"reading to edge: p50 {np.percentile(lat, 50):.3f} ms, p99 "
                  f"{np.percentile(lat, 99):.3f} ms, max {lat.max():.3f} ms over {len(lat)} pulses")
            noise = b.hello()["axes"][0]["calibration"]["noise_m"]
            smallest = 30 * noise / info["r2_m"]
            print(f"trigger rate at {top:.4g} rad/s (the noise rule's smallest step "
                  f"{smallest:.3g} rad):")
            for factor in (10, 4, 2, 1):
                step = factor * smallest * 1.0001
                account, pulses = scan(b, where, 0.03, top, step)
                where += 0.03
                print(f"  step {step:.3g} rad: {top / step:7.1f} pulses/s, "
                      f"{account['triggers']['fired']} fired, {account['triggers']['late']} late")
    finally:
        process.terminate()
        process.wait()
    process, address = board(piezod, source, port + 2, work + "-quiet", "sensor.sim.noise_m=2e-8")
    try:
        with Board(address) as b:
            b.calibrate(progress=False)
            top = b.hello()["axes"][0]["velocity_max_rad_per_s"]
            rate = b.hello()["sensor_rate_hz"]
            print(f"a sensor of 0.02 um noise: trigger rate at {top:.4g} rad/s (one reading's "
                  f"travel {top / rate:.3g} rad):")
            where = 0.0
            for readings in (8, 4, 2, 1.5, 1, 0.5):
                step = readings * top / rate
                account, pulses = scan(b, where, 0.03, top, step, width=2e-4)
                where += 0.03
                print(f"  step {step:.3g} rad ({readings:g} readings' travel): "
                      f"{top / step:7.1f} pulses/s, {account['triggers']['fired']} fired, "
                      f"{account['triggers']['late']} late")
    finally:
        process.terminate()
        process.wait()


if __name__ == "__main__":
    main()
