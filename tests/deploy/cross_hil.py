#!/usr/bin/python3
"""Across architectures: the arm64 piezod (the board build) under
qemu-aarch64, driven by this machine's native `piezo run --rig`.
1. The simulated rig on the virtual clock: a 4.8 s run whose angle agrees
   with the native one-machine run within the sensor noise.
2. The Modbus backends against the native `piezo rig-sim`: a run completes
   and the module's analog-output register (read with mbpoll) ends at 0.
Exits 77 (CTest: skipped) saying why when the arm64 build or qemu is missing.
usage: cross_hil.py ARM64_PIEZOD PIEZO SOURCE_DIR WORK_DIR PORT"""
import json
import os
import shutil
import subprocess
import sys
import time

import h5py
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
import peers  # noqa: E402
from peers import wait_for_tcp  # noqa: E402

arm64_piezod, piezo, source, work, port = sys.argv[1:6]
port = int(port)
# A directory of its own, emptied: a second run of the suite finds no old runs.
work = os.path.join(work, "cross-hil")
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
qemu = shutil.which("qemu-aarch64")
if not os.path.exists(arm64_piezod):
    print(f"SKIP: no arm64 piezod at {arm64_piezod} (cmake --preset arm64 && cmake --build "
          "--preset arm64)")
    sys.exit(77)
if qemu is None:
    print("SKIP: qemu-aarch64 not installed (Debian: qemu-user)")
    sys.exit(77)
NOISE_RAD = 0.5e-6 / 0.062  # configs/sim.toml: sensor noise over r2
failures = []
procs = []




def spawn(args, log):
    p = peers.spawn(args, stdout=open(log, "w"), stderr=subprocess.STDOUT)
    procs.append(p)
    return p


def run(args):
    r = subprocess.run(args, capture_output=True, text=True, timeout=300)
    if r.returncode != 0:
        failures.append(f"{' '.join(args[:3])}... exited {r.returncode}: {r.stderr[-400:]}")
    return r


def theta(log):
    with h5py.File(log, "r") as f:
        return f["axes/rotor/sensor/t"][:], f["axes/rotor/sensor/theta"][:]


try:
    # 1. Simulated rig, virtual clock.
    address = f"tcp://127.0.0.1:{port}"
    board = spawn([qemu, arm64_piezod, "--config", f"{source}/configs/piezod-sim.toml",
                   "--set", "run.clock=virtual", "--listen", address], f"{work}/piezod-sim.log")
    if not wait_for_tcp(port):
        failures.append("the arm64 piezod did not listen")
    hello = run([piezo, "status", "--rig", address, "--json"])
    virtual = ["--set", "run.clock=virtual"]
    remote = run([piezo, "run", "--config", f"{source}/configs/sim.toml", *virtual, "--rig", address,
                  "--json", "--out", f"{work}/arm64"])
    local = run([piezo, "run", "--config", f"{source}/configs/sim.toml", *virtual, "--json",
                 "--out", f"{work}/native"])
    board.terminate()
    board.wait(30)
    if not failures:
        r, n = json.loads(remote.stdout), json.loads(local.stdout)
        t_r, th_r = theta(f"{work}/arm64/run.h5")
        t_n, th_n = theta(f"{work}/native/run.h5")
        same_grid = len(t_r) == len(t_n) and np.allclose(t_r, t_n)
        rms = float(np.sqrt(np.nanmean((th_r - th_n) ** 2))) if same_grid else float("nan")
        print(f"4.8 s on the virtual clock: theta_end arm64 {r['theta_end_rad']:.6f} rad, native "
              f"{n['theta_end_rad']:.6f} rad; angle traces differ by {rms:.2e} rad rms "
              f"(sensor noise {NOISE_RAD:.1e} rad); {r['drive']['samples']} drive samples")
        if r["status"] != "completed" or not same_grid or not rms < NOISE_RAD:
            failures.append("the arm64 board's run does not match the native run within the noise")

    # 2. Modbus backends against the native rig-sim.
    modbus_port = port + 2
    board_port = port + 4
    baddress = f"tcp://127.0.0.1:{board_port}"
    config = f"{source}/configs/modbus-hil.toml"
    spawn([piezo, "rig-sim", "--config", config, "--tcp", f"127.0.0.1:{modbus_port}"],
          f"{work}/rig-sim.log")
    if not wait_for_tcp(modbus_port):
        failures.append("rig-sim did not listen")
    sets = ["--set", f"sensor.modbus.port={modbus_port}", "--set", f"drive.modbus-ao.port={modbus_port}"]
    board = spawn([qemu, arm64_piezod, "--config", config, *sets, "--listen", baddress],
                  f"{work}/piezod-modbus.log")
    if not wait_for_tcp(board_port):
        failures.append("the arm64 piezod on Modbus did not listen")
    m = run([piezo, "run", "--config", config, "--rig", baddress, "--duration", "2", "--json",
             "--out", f"{work}/modbus"])
    ao = subprocess.run(["mbpoll", "-m", "tcp", "-a", "1", "-t", "4", "-r", "1", "-c", "1", "-1",
                         "-p", str(modbus_port), "127.0.0.1"],
                        capture_output=True, text=True).stdout
    register = [line.split(":")[1].strip() for line in ao.splitlines() if line.startswith("[1]:")]
    if not failures:
        s = json.loads(m.stdout)
        print(f"Modbus: {s['status']}, {s['drive']['samples']} drive and {s['sensor']['samples']} "
              f"sensor samples, analog output after the run: {register}")
        if s["status"] != "completed" or register != ["0"]:
            failures.append("the Modbus run over the arm64 board did not complete at 0 V")
finally:
    for p in procs:
        if p.poll() is None:
            p.terminate()
            try:
                p.wait(30)
            except subprocess.TimeoutExpired:
                p.kill()

for f in failures:
    print("FAIL:", f)
print("cross-architecture HIL: ok" if not failures else "cross-architecture HIL: failed")
sys.exit(1 if failures else 0)
