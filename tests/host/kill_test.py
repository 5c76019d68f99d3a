#!/usr/bin/env python3
"""kill -9 at random instants, and nothing flushed is lost.

usage: kill_test.py PIEZO PIEZOD SOURCE_DIR WORK_DIR [--kills N] [--daemon-kills M]
                    [--group-kills G] [--scan-kills K] [--seed S] [--port P]

1. `piezo run` on the virtual clock (deterministic: every run writes the same
   samples), killed with SIGKILL at N instants drawn uniformly over a run's
   wall time (the log's flush every 20 ms, so many land inside a flush).
   Every run directory must then be readable, or recoverable by
   `piezo recover`, with samples that are a bit-identical prefix of an
   unkilled reference run and at least as many as run.h5 held before
   recovery.
2. The board: `piezo run --rig` against piezod, piezod killed with SIGKILL at
   M instants. The host must end the run by itself (the lease) and leave a
   whole log marked failed, with a prefix of its samples; then the host is
   killed during remote runs too, and recovered the same way.
3. A group move of three axes (configs/three-axes.toml) on the virtual clock,
   killed at G instants: every log readable after `piezo recover`, and each
   axis's own columns (under /axes/NAME) equally long and a bit-identical
   prefix of that axis's in an unkilled group move.
4. A fly scan of two axes (`piezo scan`, calibrated first) on the virtual
   clock, killed at K instants: after `piezo recover`, each axis's trigger
   pulses (/axes/NAME/triggers) a prefix, pulse by pulse, of those of an
   unkilled scan, as are its samples.

Prints the figures and exits 1 on the first broken promise, with its reason.
"""

import atexit
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import time

import h5py
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
import peers  # noqa: E402
from peers import wait_for_tcp  # noqa: E402

args = sys.argv[1:]
piezo, piezod, source, work = args[:4]


def option(name, default):
    return type(default)(args[args.index(name) + 1]) if name in args else default


kills = option("--kills", 200)
daemon_kills = option("--daemon-kills", 20)
group_kills = option("--group-kills", 20)
scan_kills = option("--scan-kills", 12)
rng = random.Random(option("--seed", 1))
port = option("--port", 5871)
config = f"{source}/configs/sim.toml"
virtual = ["--set", "run.clock=virtual", "--set", "run.flush_interval_s=0.02"]
DURATION = "4"
STOPPED = 2  # DrivePhase::stopped (firmware/include/piezo/firmware/samples.hpp)
# Each axis's columns, under its group (docs/run-logs.md).
AXIS_COLUMNS = ["drive/t", "drive/V", "drive/phase", "sensor/t", "sensor/theta", "observer/t",
                "observer/theta_hat"]


def columns_of(axes):
    return [f"axes/{axis}/{c}" for axis in axes for c in AXIS_COLUMNS]


COLUMNS = columns_of(["rotor"])
GROUP_AXES = ["theta", "phi", "chi"]

shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
failures = []
children = []  # piezod: never left behind, even on an exception
atexit.register(lambda: [c.kill() for c in children if c.poll() is None])


def fail(message):
    failures.append(message)
    print("FAIL:", message, flush=True)


def read(path, columns=COLUMNS):
    with h5py.File(path, "r") as f:
        return f.attrs["status"].decode(), {c: f[c][:] for c in columns}


def drive_rows(path, axis="rotor"):
    """Rows of an axis run.h5 holds as it is, or None when h5py cannot read it."""
    try:
        with h5py.File(path, "r") as f:
            return len(f[f"axes/{axis}/drive/t"])
    except Exception:  # noqa: BLE001 - any failure to read is "unreadable"
        return None


def is_prefix(part, whole):
    return len(part) <= len(whole) and np.array_equal(part, whole[: len(part)], equal_nan=True)


def check_recovered(run_dir, reference, label, axes=("rotor",)):
    """Recovers run_dir; returns (class, the first axis's drive rows) or
    records a failure. Each axis's columns are checked on their own."""
    log = f"{run_dir}/run.h5"
    columns = columns_of(axes)
    if not os.path.exists(log) and not os.path.exists(f"{run_dir}/run.journal"):
        return "before the log", 0
    before = drive_rows(log, axes[0]) if os.path.exists(log) else None
    r = subprocess.run([piezo, "recover", run_dir, "--json"], capture_output=True, text=True,
                       timeout=60)
    if r.returncode != 0:
        fail(f"{label}: piezo recover exited {r.returncode}: {r.stderr.strip()}")
        return "failed", 0
    rec = json.loads(r.stdout)
    try:
        with h5py.File(log, "r") as f:
            nothing = "axes" not in f.attrs and "axes" not in f and "drive" not in f
        if nothing:  # killed inside the journal's header: no axis, no row was recorded
            return "before the journal's header", 0
        status, data = read(log, columns)
    except Exception as e:  # noqa: BLE001
        fail(f"{label}: run.h5 unreadable after recovery: {e}")
        return "failed", 0
    for axis in axes:
        for group in ("drive", "sensor", "observer"):
            lengths = {len(data[c]) for c in columns if c.startswith(f"axes/{axis}/{group}/")}
            if len(lengths) != 1:
                fail(f"{label}: axis {axis}'s {group} columns of unequal length {lengths}")
    if reference is not None:
        for c in columns:
            if not is_prefix(data[c], reference[c]):
                fail(f"{label}: {c} is not a prefix of the reference run")
    n = len(data[f"axes/{axes[0]}/drive/t"])
    if before is not None and n < before:
        fail(f"{label}: recovery kept {n} drive rows, run.h5 held {before}")
    if rec["rebuilt"]:
        return ("torn journal tail" if rec["torn_bytes"] else "rebuilt") + (
            ", run.h5 was unreadable" if before is None and os.path.exists(f"{log}.damaged")
            else ""), n
    return f"whole ({status})", n


# The reference: one run that nobody kills.
start = time.monotonic()
subprocess.run([piezo, "run", "--config", config, *virtual, "--duration", DURATION, "--json",
                "--out", f"{work}/reference"], check=True, capture_output=True, timeout=300)
wall = time.monotonic() - start
_, reference = read(f"{work}/reference/run.h5")
print(f"reference: {len(reference['axes/rotor/drive/t'])} drive samples in {wall:.2f} s wall", flush=True)

# 1. The host, killed.
classes = {}
fractions = []
t0 = time.monotonic()
for i in range(kills):
    run_dir = f"{work}/host-{i:03d}"
    p = peers.spawn([piezo, "run", "--config", config, *virtual, "--duration", DURATION,
                          "--json", "--out", run_dir], stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL)
    time.sleep(rng.uniform(0.0, 1.1 * wall))
    p.send_signal(signal.SIGKILL)
    p.wait()
    if not os.path.isdir(run_dir):
        cls, n = "before the run directory", 0
    else:
        cls, n = check_recovered(run_dir, reference, f"host kill {i}")
    classes[cls] = classes.get(cls, 0) + 1
    fractions.append(n / len(reference["axes/rotor/drive/t"]))
print(f"host: {kills} kills in {time.monotonic() - t0:.1f} s", flush=True)
for cls, count in sorted(classes.items()):
    print(f"  {count:4d}  {cls}")
print(f"  drive samples kept: {min(fractions):.3f} to {max(fractions):.3f} of the run", flush=True)


# 3. A group move of three axes, killed.
group_config = f"{source}/configs/three-axes.toml"
group_move = [piezo, "move", "--config", group_config, *virtual, "--to", "theta=0.004",
              "--to", "phi=-0.006", "--to", "chi=0.003", "--timeout", "20", "--json"]
start = time.monotonic()
subprocess.run([*group_move, "--out", f"{work}/group-reference"], check=True,
               capture_output=True, timeout=300)
group_wall = time.monotonic() - start
_, group_reference = read(f"{work}/group-reference/run.h5", columns_of(GROUP_AXES))
print(f"group reference: {[len(group_reference[f'axes/{a}/drive/t']) for a in GROUP_AXES]} "
      f"drive samples of {', '.join(GROUP_AXES)} in {group_wall:.2f} s wall", flush=True)
group_classes = {}
for i in range(group_kills):
    run_dir = f"{work}/group-{i:03d}"
    p = peers.spawn([*group_move, "--out", run_dir], stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL)
    time.sleep(rng.uniform(0.0, 1.1 * group_wall))
    p.send_signal(signal.SIGKILL)
    p.wait()
    cls, _ = check_recovered(run_dir, group_reference, f"group kill {i}", GROUP_AXES) \
        if os.path.isdir(run_dir) else ("before the run directory", 0)
    group_classes[cls] = group_classes.get(cls, 0) + 1
print(f"group moves: {group_kills} kills", flush=True)
for cls, count in sorted(group_classes.items()):
    print(f"  {count:4d}  {cls}")


# 4. A scan of two axes, killed.
TRIGGER_COLUMNS = ["k", "angle_rad", "edge_s"]
SCAN_AXES = ["theta", "phi"]
calibrated = ["--set", f"piezod.calibration_file={work}/calibration.json"]
for axis in SCAN_AXES:
    subprocess.run([piezo, "calibrate", "--config", group_config, *virtual, *calibrated, "--axis",
                    axis, "--out", f"{work}/calibration-{axis}"], check=True, capture_output=True,
                   timeout=300)
scan = [piezo, "scan", "--config", group_config, *virtual, *calibrated, "--from", "theta=0",
        "--to", "theta=0.03", "--velocity", "theta=0.02", "--from", "phi=0", "--to", "phi=-0.03",
        "--velocity", "phi=0.03", "--trigger-step", "0.002", "--json"]


def triggers(path):
    with h5py.File(path, "r") as f:
        return {a: {c: f[f"axes/{a}/triggers/{c}"][:] for c in TRIGGER_COLUMNS} for a in SCAN_AXES}


start = time.monotonic()
subprocess.run([*scan, "--out", f"{work}/scan-reference"], check=True, capture_output=True,
               timeout=300)
scan_wall = time.monotonic() - start
_, scan_reference = read(f"{work}/scan-reference/run.h5", columns_of(SCAN_AXES))
trigger_reference = triggers(f"{work}/scan-reference/run.h5")
print(f"scan reference: {[len(trigger_reference[a]['k']) for a in SCAN_AXES]} pulses of "
      f"{', '.join(SCAN_AXES)} in {scan_wall:.2f} s wall", flush=True)
scan_classes, kept_pulses = {}, []
for i in range(scan_kills):
    run_dir = f"{work}/scan-{i:03d}"
    p = peers.spawn([*scan, "--out", run_dir], stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL)
    time.sleep(rng.uniform(0.0, 1.1 * scan_wall))
    p.send_signal(signal.SIGKILL)
    p.wait()
    cls, _ = check_recovered(run_dir, scan_reference, f"scan kill {i}", SCAN_AXES) \
        if os.path.isdir(run_dir) else ("before the run directory", 0)
    scan_classes[cls] = scan_classes.get(cls, 0) + 1
    if cls in ("before the log", "before the run directory", "before the journal's header",
               "failed"):
        continue
    kept = triggers(f"{run_dir}/run.h5")
    for axis in SCAN_AXES:
        for c in TRIGGER_COLUMNS:
            if not is_prefix(kept[axis][c], trigger_reference[axis][c]):
                fail(f"scan kill {i}: axis {axis}'s triggers/{c} is no prefix of the "
                     f"unkilled scan's")
    kept_pulses.append(sum(len(kept[a]["k"]) for a in SCAN_AXES))
print(f"scans: {scan_kills} kills; pulses kept: {sorted(kept_pulses)}", flush=True)
for cls, count in sorted(scan_classes.items()):
    print(f"  {count:4d}  {cls}")


# 2. The board, killed; then the host during remote runs.


address = f"tcp://127.0.0.1:{port}"
spill = f"{work}/piezod.spill"
board_args = [piezod, "--config", f"{source}/configs/piezod-sim.toml", "--set",
              "run.clock=virtual", "--set", f"piezod.spill_file={spill}", "--listen", address]
remote = ["run", "--config", config, *virtual, "--duration", DURATION, "--rig", address, "--json"]


def start_board():
    b = peers.spawn(board_args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    children.append(b)
    if not wait_for_tcp(port):
        fail("piezod did not listen")
    return b


board = start_board()
start = time.monotonic()
subprocess.run([piezo, *remote, "--out", f"{work}/remote-reference"], capture_output=True,
               timeout=300)
remote_wall = time.monotonic() - start
board_classes = {}
for i in range(daemon_kills):
    run_dir = f"{work}/board-{i:03d}"
    host_err = open(f"{run_dir}.stderr", "w")
    host = peers.spawn([piezo, *remote, "--out", run_dir], stdout=subprocess.PIPE,
                            stderr=host_err, text=True)
    time.sleep(rng.uniform(0.05, 0.9 * remote_wall))
    board.send_signal(signal.SIGKILL)
    board.wait()
    try:
        out, _ = host.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        host.kill()
        fail(f"board kill {i}: the host did not end the run")
        out = ""
    host_err.close()
    status = drive_rows(f"{run_dir}/run.h5")
    st = None
    if not os.path.isdir(run_dir):
        # The board died before it answered the host's hello: nothing was
        # started, so there is no run and no log; the host must say so.
        if host.returncode == 0:
            fail(f"board kill {i}: the host exited 0 without a run directory")
        cls = f"none: board gone before the start (exit {host.returncode})"
        board_classes[cls] = board_classes.get(cls, 0) + 1
    elif status is None:
        fail(f"board kill {i}: the host's run.h5 is unreadable (exit {host.returncode}); "
             f"its stderr: {open(f'{run_dir}.stderr').read().strip()}")
    else:
        with h5py.File(f"{run_dir}/run.h5", "r") as f:
            st = f.attrs["status"].decode()
        if st == "incomplete":
            fail(f"board kill {i}: the host left its log incomplete")
        board_classes[f"{st} (exit {host.returncode})"] = board_classes.get(
            f"{st} (exit {host.returncode})", 0) + 1
        if os.path.exists(f"{run_dir}/run.journal") and st != "failed":
            fail(f"board kill {i}: a journal was left beside a whole log")
    board = start_board()
    # The restarted board kept the killed one's spill file: every sample it
    # recorded, at least as many as reached the host.
    if st == "failed" and os.path.exists(f"{spill}.previous"):
        r = subprocess.run([piezo, "recover", f"{run_dir}-board", "--spill", f"{spill}.previous",
                            "--json"], capture_output=True, text=True, timeout=60)
        if r.returncode != 0:
            fail(f"board kill {i}: recover --spill exited {r.returncode}: {r.stderr.strip()}")
        else:
            spilled = json.loads(r.stdout)["drive_samples"]
            with h5py.File(f"{run_dir}/run.h5", "r") as f:
                host_rows = len(f["axes/rotor/drive/t"])
            with h5py.File(f"{run_dir}-board/run.h5", "r") as f:
                # The stop record (phase stopped or output_unconfirmed) is
                # stamped when the output stopped, off the cycle grid.
                cycles = f["axes/rotor/drive/t"][:][f["axes/rotor/drive/phase"][:] < STOPPED]
                steps = np.diff(cycles)
            if spilled < host_rows - 1:  # the host's log may end with the stop record
                fail(f"board kill {i}: the spill holds {spilled} drive samples, the host {host_rows}")
            off_grid = np.flatnonzero(np.abs(steps - 1e-4) > 1e-9)
            if len(off_grid):
                k = off_grid[0]
                fail(f"board kill {i}: the spill's drive times have a gap: "
                     f"{cycles[k]:.6f} s to {cycles[k + 1]:.6f} s ({len(off_grid)} such steps)")
            board_classes["spill recovered"] = board_classes.get("spill recovered", 0) + 1
        os.remove(f"{spill}.previous")
print(f"board: {daemon_kills} piezod kills", flush=True)
for cls, count in sorted(board_classes.items()):
    print(f"  {count:4d}  host's log {cls}")

remote_classes = {}
for i in range(daemon_kills):
    run_dir = f"{work}/remote-host-{i:03d}"
    p = peers.spawn([piezo, *remote, "--out", run_dir], stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL)
    time.sleep(rng.uniform(0.0, 1.1 * remote_wall))
    p.send_signal(signal.SIGKILL)
    p.wait()
    cls, _ = check_recovered(run_dir, None, f"remote host kill {i}") if os.path.isdir(
        run_dir) else ("before the run directory", 0)
    remote_classes[cls] = remote_classes.get(cls, 0) + 1
    # The board stops by itself (lease) and takes the next start.
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        r = subprocess.run([piezo, "status", "--rig", address, "--json"], capture_output=True,
                           text=True, timeout=30)
        if r.returncode == 0 and json.loads(r.stdout).get("state") in ("idle", "fault"):
            break
        time.sleep(0.1)
print(f"host during remote runs: {daemon_kills} kills", flush=True)
for cls, count in sorted(remote_classes.items()):
    print(f"  {count:4d}  {cls}")
board.send_signal(signal.SIGTERM)
board.wait(timeout=30)

if failures:
    print(f"{len(failures)} failures")
    sys.exit(1)
print("every killed run is readable or recovered, with every sample a prefix of the run")
