#!/usr/bin/env python3
"""Soak: long runs with faults injected throughout.

usage: soak.py PIEZO PIEZOD SOURCE_DIR WORK_DIR [--hours H] [--modbus-cycles N]
               [--pauses N] [--port P]

1. One long run in process on the virtual clock (H simulated hours, default
   1) with sensor dropouts throughout (2 % of reads), the observer on. The
   log must hold every sample the board counted (drive at 10 kHz without a
   gap, sensor at 1 kHz), every dropout counted once (NaN angle, status
   set), nothing dropped; memory (VmRSS, polled) stays flat while the file
   grows with the samples.
2. Modbus against `piezo rig-sim` in real time, N cycles of 3 s: exception
   replies and dropped requests throughout (counted, the run goes on),
   every other cycle a disconnect of every client (the run must stop with a
   sensor or drive fault); after every cycle that rig-sim survives, its
   analog-output register, read by mbpoll, is 0.
3. Link outages to piezod: the host of `piezo run --rig` is frozen
   (SIGSTOP) for a moment shorter than the lease (the run goes on, and the
   log is complete, the gap fetched from the board's recorder) or longer
   (the board stops by itself with link_lost and the drive at 0 V).

Prints the figures; exits 1 with the reasons on any broken promise.
"""

import atexit
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
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


hours = option("--hours", 1.0)
modbus_cycles = option("--modbus-cycles", 6)
pauses = option("--pauses", 4)
port = option("--port", 5891)
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
failures = []
children = []  # rig-sim and piezod: never left behind, even on an exception
atexit.register(lambda: [c.kill() for c in children if c.poll() is None])


def check(condition, message):
    if not condition:
        failures.append(message)
        print("FAIL:", message, flush=True)
    return condition




class MemoryWatch:
    """Polls a process's VmRSS; keeps (wall time, kB) pairs and VmHWM."""

    def __init__(self, pid):
        self.pid, self.samples, self.hwm = pid, [], 0
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self):
        while True:
            try:
                status = open(f"/proc/{self.pid}/status").read()
            except OSError:
                return
            fields = dict(line.split(":", 1) for line in status.splitlines() if ":" in line)
            if "VmRSS" not in fields:
                return
            self.samples.append((time.monotonic(), int(fields["VmRSS"].split()[0])))
            self.hwm = max(self.hwm, int(fields["VmHWM"].split()[0]))
            time.sleep(0.25)


# 1. The long run.
duration = 3600.0 * hours
run_dir = f"{work}/long"
start = time.monotonic()
p = peers.spawn([piezo, "run", "--config", f"{source}/configs/sim.toml", "--set",
                      "run.clock=virtual", "--set", "sensor.sim.dropout_probability=0.02",
                      "--set", "safety.max_sensor_errors=1000", "--duration", str(duration),
                      "--json", "--out", run_dir], stdout=subprocess.PIPE, text=True)
memory = MemoryWatch(p.pid)
sizes = []
while p.poll() is None:
    if os.path.exists(f"{run_dir}/run.h5"):
        sizes.append((time.monotonic(), os.path.getsize(f"{run_dir}/run.h5")))
    time.sleep(1.0)
out = p.stdout.read()
wall = time.monotonic() - start
check(p.returncode == 0, f"long run exited {p.returncode}")
summary = json.loads(out)
with h5py.File(f"{run_dir}/run.h5", "r") as f:
    status = f.attrs["status"].decode()
    drive_t = f["axes/rotor/drive/t"][:]
    theta = f["axes/rotor/sensor/theta"][:]
    sensor_status = f["axes/rotor/sensor/status"][:]
    observer_n = len(f["axes/rotor/observer/t"])
size = os.path.getsize(f"{run_dir}/run.h5")
check(status == "completed", f"long run log {status}")
drive_n, sensor_n = len(drive_t), len(theta)
# The log's last drive record is the stop (the board counts periods' samples).
check(drive_n == summary["drive"]["samples"] + 1,
      f"drive samples: log {drive_n}, board {summary['drive']['samples']} + the stop record")
check(sensor_n == summary["sensor"]["samples"],
      f"sensor samples: log {sensor_n}, board {summary['sensor']['samples']}")
check(summary["drive"]["dropped"] == 0 and summary["sensor"]["dropped"] == 0,
      f"dropped: drive {summary['drive']['dropped']}, sensor {summary['sensor']['dropped']}")
steps = np.diff(drive_t[:-1])  # the last record is the stop
check(np.allclose(steps, 1e-4, rtol=0, atol=1e-9), "drive times have a gap or a repeat")
errors = int(np.count_nonzero(np.isnan(theta)))
check(errors == int(np.count_nonzero(sensor_status)),
      f"NaN angles {errors} != failed statuses {np.count_nonzero(sensor_status)}")
check(errors == summary["sensor"]["errors"],
      f"dropouts in the log {errors}, counted by the board {summary['sensor']['errors']}")
check(abs(errors / sensor_n - 0.02) < 0.005, f"dropout rate {errors / sensor_n:.4f}")
# Memory: flat once the buffers have warmed up -- the last quarter of the
# run against the second (medians, so that one flush's peak does not count).
def median_rss(lo, hi):
    kb = sorted(k for t, k in memory.samples if start + lo * wall <= t <= start + hi * wall)
    return kb[len(kb) // 2] / 1024 if kb else 0.0


growth_mb = median_rss(0.75, 1.0) - median_rss(0.25, 0.5)
check(growth_mb < 16, f"memory grew {growth_mb:.1f} MB from the run's second quarter to its last")
mb_per_hour = size / 1e6 / hours
print(f"long run: {duration:.0f} s simulated in {wall:.1f} s wall; {drive_n} drive, {sensor_n} "
      f"sensor ({errors} dropouts, all counted), {observer_n} observer samples; dropped 0; "
      f"memory high-water {memory.hwm / 1024:.1f} MB, growth from the second quarter to the last "
      f"{growth_mb:+.1f} MB; "
      f"log {size / 1e6:.1f} MB ({mb_per_hour:.0f} MB per simulated hour)", flush=True)

# 2. Modbus faults against rig-sim, real time.
modbus_port = port + 10
config = f"{source}/configs/modbus-hil.toml"
sets = ["--set", f"sensor.modbus.port={modbus_port}", "--set", f"drive.modbus-ao.port={modbus_port}"]
outcomes = {}
sensor_errors = 0
for cycle in range(modbus_cycles):
    disconnect = cycle % 2 == 1
    faults = ["--set", "rig_sim.exception_probability=0.002", "--set",
              "rig_sim.drop_probability=0.002"]
    if disconnect:
        faults += ["--set", "rig_sim.disconnect_at_s=1.5"]
    rig = peers.spawn([piezo, "rig-sim", "--config", config, *sets, *faults, "--tcp",
                            f"127.0.0.1:{modbus_port}"], stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL)
    children.append(rig)
    check(wait_for_tcp(modbus_port), "rig-sim did not listen")
    r = subprocess.run([piezo, "run", "--config", config, *sets, "--duration", "3", "--json",
                        "--out", f"{work}/modbus-{cycle:02d}"], capture_output=True, text=True,
                       timeout=120)
    s = json.loads(r.stdout) if r.stdout.strip() else {}
    cause = s.get("stop_cause", "?")
    sensor_errors += s.get("sensor", {}).get("errors", 0)
    outcomes[cause] = outcomes.get(cause, 0) + 1
    if disconnect:
        check(cause in ("sensor_fault", "drive_fault"), f"modbus cycle {cycle}: {cause}")
    else:
        # A failed write to the drive stops the run (drive_fault, ramp to 0 V):
        # the safety rule for the drive; failed sensor reads are counted.
        check(cause in ("completed", "drive_fault", "sensor_fault"),
              f"modbus cycle {cycle}: {cause} ({r.stderr[-200:]})")
        ao = subprocess.run(["mbpoll", "-m", "tcp", "-a", "1", "-t", "4", "-r", "1", "-c", "1",
                             "-1", "-p", str(modbus_port), "127.0.0.1"], capture_output=True,
                            text=True, timeout=30)
        check("[1]: \t0" in ao.stdout or "[1]:\t0" in ao.stdout,
              f"modbus cycle {cycle}: AO register not 0: {ao.stdout[-120:]}")
    with h5py.File(f"{work}/modbus-{cycle:02d}/run.h5", "r") as f:
        check(f.attrs["status"].decode() in ("completed", "failed"),
              f"modbus cycle {cycle}: log {f.attrs['status']}")
        if disconnect:
            # Nothing reaches a module that is gone: the log must say so, not
            # claim 0 V (its watchdog zeroes the output by itself).
            check(f.attrs["output"].decode() == "output_unconfirmed",
                  f"modbus cycle {cycle}: output {f.attrs['output']}")
        elif f.attrs["output"].decode() == "confirmed":
            check(float(f["axes/rotor/drive/V"][-1]) == 0.0, f"modbus cycle {cycle}: last command not 0 V")
    rig.send_signal(signal.SIGTERM)
    rig.wait(timeout=30)
print(f"modbus: {modbus_cycles} cycles with exceptions and drops (0.2 % each), a disconnect "
      f"every other cycle; stop causes {outcomes}; sensor errors counted {sensor_errors}",
      flush=True)

# 3. Link outages to piezod: the host frozen shorter or longer than the lease.
address = f"tcp://127.0.0.1:{port}"
board = peers.spawn([piezod, "--config", f"{source}/configs/piezod-sim.toml", "--listen",
                          address], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
children.append(board)
check(wait_for_tcp(port), "piezod did not listen")
link = {}
for i in range(pauses):
    long_pause = i % 2 == 1
    run_dir = f"{work}/link-{i:02d}"
    host = peers.spawn([piezo, "run", "--config", f"{source}/configs/sim.toml", "--rig",
                             address, "--duration", "3", "--json", "--out", run_dir],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    time.sleep(1.5)
    host.send_signal(signal.SIGSTOP)
    time.sleep(1.2 if long_pause else 0.2)  # the lease is 0.5 s
    host.send_signal(signal.SIGCONT)
    out, _ = host.communicate(timeout=60)
    s = json.loads(out) if out.strip() else {}
    cause = s.get("stop_cause", "?")
    link[cause] = link.get(cause, 0) + 1
    check(cause == ("link_lost" if long_pause else "completed"), f"link pause {i}: {cause}")
    state = json.loads(subprocess.run([piezo, "status", "--rig", address, "--json"],
                                      capture_output=True, text=True, timeout=30).stdout)
    if long_pause:
        # The board latched link_lost by itself; a new run needs a reset.
        check(state.get("fault") == "link_lost", f"link pause {i}: board fault {state.get('fault')}")
        subprocess.run([piezo, "reset-fault", "--rig", address], capture_output=True, timeout=30)
    with h5py.File(f"{run_dir}/run.h5", "r") as f:
        n = len(f["axes/rotor/drive/t"])
        check(n == s.get("drive", {}).get("samples", -2) + 1,
              f"link pause {i}: log {n} drive samples, board {s.get('drive', {}).get('samples')}"
              " + the stop record")
        check(float(f["axes/rotor/drive/V"][-1]) == 0.0, f"link pause {i}: last command not 0 V")
board.send_signal(signal.SIGTERM)
board.wait(timeout=30)
print(f"link: {pauses} host freezes (0.2 s and 1.2 s against a 0.5 s lease); stop causes {link}",
      flush=True)

if failures:
    print(f"{len(failures)} failures")
    sys.exit(1)
print("soak passed")
