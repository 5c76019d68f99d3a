#!/usr/bin/python3
"""The link cut on a real network stack: piezod in one network namespace,
`piezo run --rig` in another, joined by a veth pair, with CURVE keys as on a
real network. Mid-run the board's side of the link goes down for 2 s.
Checks, from the board's own samples (the host's log holds all of them once
the gaps are fetched): the drive reached 0 V and stopped within the lease
plus the ramp after the cut, link_lost is latched, and after the link came
back the host fetched every sample the board recorded.
Exits 77 (CTest: skipped) saying why when namespaces are not permitted.
usage: netns_link_cut.py PIEZOD PIEZO SOURCE_DIR WORK_DIR PORT"""
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

piezod, piezo, source, work, port = sys.argv[1:6]
# A directory of its own, emptied: a second run of the suite finds no old
# keys (keygen keeps a pair unless forced) and no old run.
work = os.path.join(work, "netns-link-cut")
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
tag = str(os.getpid())
board_ns, host_ns = f"pz-board-{tag}", f"pz-host-{tag}"
veth_board, veth_host = f"pzb{tag}"[:15], f"pzh{tag}"[:15]
board_ip, host_ip = "10.231.0.1", "10.231.0.2"
address = f"tcp://{board_ip}:{port}"
LEASE_S, RAMP_S = 0.5, 80.0 / 1000.0  # piezod-sim.toml: lease 0.5 s, V_max 80 V at 1000 V/s


def sh(*args, check=True):
    return subprocess.run(args, check=check, capture_output=True, text=True)


def in_ns(ns, *args):
    return ["ip", "netns", "exec", ns, *args]


if os.geteuid() != 0:
    print("SKIP: network namespaces need root")
    sys.exit(77)
try:
    sh("ip", "netns", "add", board_ns)
except (subprocess.CalledProcessError, FileNotFoundError) as e:
    print(f"SKIP: cannot create a network namespace here ({e})")
    sys.exit(77)

procs = []
try:
    sh("ip", "netns", "add", host_ns)
    sh("ip", "link", "add", veth_board, "type", "veth", "peer", "name", veth_host)
    sh("ip", "link", "set", veth_board, "netns", board_ns)
    sh("ip", "link", "set", veth_host, "netns", host_ns)
    for ns, dev, ip in ((board_ns, veth_board, board_ip), (host_ns, veth_host, host_ip)):
        sh(*in_ns(ns, "ip", "addr", "add", f"{ip}/24", "dev", dev))
        sh(*in_ns(ns, "ip", "link", "set", dev, "up"))
        sh(*in_ns(ns, "ip", "link", "set", "lo", "up"))

    # CURVE, as any network address requires: the board's key pair, the
    # host's key pair, the host's public key authorized on the board.
    keys = os.path.join(work, "keys")
    os.makedirs(keys, exist_ok=True)
    sh(piezod, "keygen", "--out", keys, "--name", "board")
    sh(piezod, "keygen", "--out", keys, "--name", "host")
    with open(os.path.join(keys, "host.pub")) as f, \
            open(os.path.join(keys, "authorized_keys"), "w") as out:
        out.write(f.read())

    board_log = open(os.path.join(work, "piezod.log"), "w")
    board = peers.spawn(in_ns(board_ns, piezod, "--config", f"{source}/configs/piezod-sim.toml",
                                   "--listen", address,
                                   "--set", f"piezod.secret_key_file=\"{keys}/board.key\"",
                                   "--set", f"piezod.authorized_keys_file=\"{keys}/authorized_keys\""),
                             stderr=board_log)
    procs.append(board)
    client_keys = ["--set", f"rig.server_public_key_file=\"{keys}/board.pub\"",
                   "--set", f"rig.client_secret_key_file=\"{keys}/host.key\""]
    status_keys = ["--server-key", f"{keys}/board.pub", "--client-key", f"{keys}/host.key"]
    for _ in range(50):
        if sh(*in_ns(host_ns, piezo, "status", "--rig", address, *status_keys),
              check=False).returncode == 0:
            break
        time.sleep(0.2)

    out_dir = os.path.join(work, "run")
    host_out = open(os.path.join(work, "host.txt"), "w")
    host = peers.spawn(in_ns(host_ns, piezo, "run", "--config", f"{source}/configs/sim.toml",
                                  "--rig", address, "--duration", "5", "--json", "--out", out_dir,
                                  *client_keys),
                            stdout=host_out, stderr=subprocess.STDOUT)
    procs.append(host)
    # The cut comes 0.5 s into the board's run, as the board says: after a
    # fixed sleep a host slow to start (a loaded machine) may not have begun.
    for _ in range(300):
        now = json.loads(sh(*in_ns(host_ns, piezo, "status", "--rig", address, "--json",
                                   *status_keys)).stdout)
        if now["state"] == "running" and now["board_ns"] - now["run"]["t0_ns"] >= 0.5e9:
            break
        time.sleep(0.05)
    cut_ns = time.monotonic_ns()  # CLOCK_MONOTONIC is the board's clock too
    sh(*in_ns(board_ns, "ip", "link", "set", veth_board, "down"))
    time.sleep(2.0)
    sh(*in_ns(board_ns, "ip", "link", "set", veth_board, "up"))
    host.wait(60)

    failures = []
    status = json.loads(sh(*in_ns(host_ns, piezo, "status", "--rig", address, "--json",
                                  *status_keys)).stdout)
    recorded = status["run"]["summary"]["samples"]
    if status.get("fault") != "link_lost":
        failures.append(f"board fault {status.get('fault')!r}, expected link_lost")
    f = h5py.File(os.path.join(out_dir, "run.h5"), "r")
    t0 = int(f.attrs["board_t0_ns"].decode())
    t_cut = (cut_ns - t0) * 1e-9
    t, V, phase = f["axes/rotor/drive/t"][:], f["axes/rotor/drive/V"][:], f["axes/rotor/drive/phase"][:]
    stopped = np.nonzero(phase == 2)[0]
    t_stop = t[stopped[0]] if len(stopped) else float("nan")
    print(f"cut at {t_cut:.3f} s of the run; the drive stopped at {t_stop:.3f} s "
          f"({t_stop - t_cut:.3f} s later; lease {LEASE_S} s + ramp {RAMP_S} s), last V {V[-1]} V")
    if not len(stopped) or V[-1] != 0.0 or np.any(V[stopped[0]:] != 0.0):
        failures.append("the drive did not end at 0 V, stopped")
    if not t_stop - t_cut <= LEASE_S + RAMP_S + 0.05:
        failures.append("the drive stopped later than the lease plus the ramp")
    counts = (len(f["axes/rotor/drive/t"]), len(f["axes/rotor/sensor/t"]))
    print(f"host log: {counts[0]} drive and {counts[1]} sensor samples; board recorded "
          f"{recorded['drive']} and {recorded['sensor']}; outages {f.attrs['link_outages'].decode()[:200]}")
    if counts != (recorded["drive"], recorded["sensor"]):
        failures.append("the host's log misses samples the board recorded")
    if not np.all(np.diff(t) > 0):
        failures.append("drive samples out of order or repeated")
    outages = f.attrs["link_outages"].decode()
    starts = [float(span.split(",")[0].strip("[ ")) for span in outages.split(";")] \
        if outages != "none" else []
    if not starts:
        failures.append("the outage is not marked in the log")
    elif min(starts) < t_cut - 0.2:
        failures.append(f"outages marked before the cut at {t_cut:.3f} s: {outages[:200]}")
    for msg in failures:
        print("FAIL:", msg)
    print("netns link cut: ok" if not failures else "netns link cut: failed")
    sys.exit(1 if failures else 0)
finally:
    for p in procs:
        if p.poll() is None:
            p.terminate()
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                p.kill()
    for ns in (board_ns, host_ns):
        sh("ip", "netns", "del", ns, check=False)
