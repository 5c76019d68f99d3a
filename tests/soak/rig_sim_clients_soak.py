#!/usr/bin/env python3
"""Soak: rig-sim serves a real-time run while strangers come and go.

usage: rig_sim_clients_soak.py PIEZO SOURCE_DIR WORK_DIR [--seconds S] [--port P]

While `piezo run` drives the simulated rig over Modbus TCP for S seconds
(default 10), 1,000 idle clients connect and leave in waves, 10 clients
drip frames a byte at a time and 10 send frames that are not Modbus
(protocol id 1, a wrong length, garbage), each reconnecting when rig-sim
closes it. The run must complete with every sample: status completed, no
drive or sensor error, every deadline served or counted, and the log
(read with h5py) holding every sample the summary counts. Then rig-sim
still answers mbpoll. Prints the figures; exits 1 with the reasons on any
broken promise.
"""

import argparse
import json
import os
import shutil
import random
import resource
import socket
import subprocess
import sys
import threading
import time

import h5py

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
import peers  # noqa: E402
from peers import wait_for_tcp  # noqa: E402

GOOD_READ = bytes([0, 1, 0, 0, 0, 6, 1, 3, 0, 0, 0, 2])
MALFORMED = [
    bytes([0, 1, 0, 1, 0, 6, 1, 3, 0, 0, 0, 2]),  # protocol id 1
    bytes([0, 1, 0xFF, 0xFF, 0, 6, 1, 3, 0, 0, 0, 2]),  # protocol id 0xFFFF
    bytes([0, 1, 0, 0, 0, 9, 1, 3, 0, 0, 0, 2, 0, 0, 0]),  # length 9 for a read
    bytes([0, 1, 0, 0, 0, 0, 1]),  # length 0
    bytes(random.Random(3).randrange(256) for _ in range(64)),  # garbage
]


class Strangers:
    """The idle, dripping and malformed clients, on threads, until stop()."""

    def __init__(self, port):
        self.port = port
        self.done = threading.Event()
        self.counts = {"idle_connections": 0, "drips": 0, "malformed_sent": 0,
                       "malformed_closed": 0, "most_idle_held": 0}
        self.lock = threading.Lock()
        self.threads = [threading.Thread(target=self.idle_waves)]
        self.threads += [threading.Thread(target=self.drip, args=(i,)) for i in range(10)]
        self.threads += [threading.Thread(target=self.malformed, args=(i,)) for i in range(10)]

    def connect(self):
        try:
            return socket.create_connection(("127.0.0.1", self.port), 1.0)
        except OSError:
            return None

    def add(self, key, n=1):
        with self.lock:
            self.counts[key] += n

    def idle_waves(self):
        """1,000 connections held for about a second, closed, again."""
        while not self.done.is_set():
            held = [s for s in (self.connect() for _ in range(1000)) if s is not None]
            self.add("idle_connections", len(held))
            with self.lock:
                self.counts["most_idle_held"] = max(self.counts["most_idle_held"], len(held))
            self.done.wait(1.0)
            for s in held:
                s.close()

    def drip(self, i):
        """A valid frame, one byte every 100 ms (rig-sim closes it past its
        frame timeout); reconnect and start again."""
        while not self.done.is_set():
            s = self.connect()
            if s is None:
                self.done.wait(0.1)
                continue
            try:
                for b in GOOD_READ:
                    if self.done.is_set():
                        break
                    s.sendall(bytes([b]))
                    self.add("drips")
                    self.done.wait(0.1)
            except OSError:
                pass
            s.close()

    def malformed(self, i):
        """A frame that is not Modbus; rig-sim must close the connection."""
        while not self.done.is_set():
            s = self.connect()
            if s is None:
                self.done.wait(0.1)
                continue
            try:
                s.sendall(MALFORMED[i % len(MALFORMED)])
                self.add("malformed_sent")
                s.settimeout(2.0)
                if s.recv(300) == b"":
                    self.add("malformed_closed")
            except OSError:
                self.add("malformed_closed")  # reset by rig-sim: closed too
            s.close()
            self.done.wait(0.05)

    def start(self):
        for t in self.threads:
            t.start()

    def stop(self):
        self.done.set()
        for t in self.threads:
            t.join()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("piezo")
    ap.add_argument("source")
    ap.add_argument("work")
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--port", type=int, default=5895)
    a = ap.parse_args()
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (min(hard, 4096), hard))
    # Emptied first: a second run of the suite finds no old run.
    shutil.rmtree(a.work, ignore_errors=True)
    os.makedirs(a.work)
    config = os.path.join(a.source, "configs", "modbus-hil.toml")
    port_set = ["--set", f"sensor.modbus.port={a.port}"]
    rig = peers.spawn([a.piezo, "rig-sim", "--config", config] + port_set,
                           stdout=subprocess.DEVNULL,
                           stderr=open(os.path.join(a.work, "rig-sim.txt"), "w"))
    problems = []
    try:
        if not wait_for_tcp(a.port):
            print("rig-sim did not start")
            return 1
        strangers = Strangers(a.port)
        strangers.start()
        time.sleep(1.0)  # the first wave is in
        out = os.path.join(a.work, "run")
        run = subprocess.run(
            [a.piezo, "run", "--config", config, "--duration", str(a.seconds), "--json",
             "--out", out, "--set", f"drive.modbus-ao.port={a.port}"] + port_set,
            capture_output=True, text=True, timeout=a.seconds + 120)
        strangers.stop()
        if run.returncode != 0:
            problems.append(f"the run exited {run.returncode}: {run.stderr.strip()[-400:]}")
        summary = json.loads(run.stdout) if run.stdout.strip() else {}
        drive, sensor = summary.get("drive", {}), summary.get("sensor", {})
        print(json.dumps({"run": {"status": summary.get("status"),
                                  "drive": {k: drive.get(k) for k in
                                            ("samples", "missed_cycles", "errors")},
                                  "sensor": {k: sensor.get(k) for k in
                                             ("samples", "missed_cycles", "errors", "dropped")}},
                          "strangers": strangers.counts}))
        if summary.get("status") != "completed":
            problems.append(f"status {summary.get('status')}")
        if drive.get("errors") != 0 or sensor.get("errors") != 0:
            problems.append(f"errors: drive {drive.get('errors')}, sensor {sensor.get('errors')}")
        rate_hz = 1000.0
        served = (drive.get("samples", 0) or 0) + (drive.get("missed_cycles", 0) or 0)
        if served < a.seconds * rate_hz:
            problems.append(f"only {served} drive deadlines of {a.seconds * rate_hz:.0f} "
                            "served or counted")
        if os.path.exists(os.path.join(out, "run.h5")):
            with h5py.File(os.path.join(out, "run.h5"), "r") as f:
                # The log ends with the board's stop record (0 V) beyond the samples.
                if len(f["axes/rotor/drive/t"]) not in (drive.get("samples"), drive.get("samples", 0) + 1):
                    problems.append(f"the log holds {len(f['axes/rotor/drive/t'])} drive samples, "
                                    f"the summary counts {drive.get('samples')}")
                if len(f["axes/rotor/sensor/t"]) != sensor.get("samples"):
                    problems.append(f"the log holds {len(f['axes/rotor/sensor/t'])} sensor samples, "
                                    f"the summary counts {sensor.get('samples')}")
        else:
            problems.append("no run.h5")
        c = strangers.counts
        if c["most_idle_held"] < 1000:
            problems.append(f"only {c['most_idle_held']} idle clients held at once")
        if c["malformed_closed"] < c["malformed_sent"] - 10:
            problems.append(f"{c['malformed_sent']} malformed frames sent, only "
                            f"{c['malformed_closed']} connections closed for them")
        if rig.poll() is not None:
            problems.append(f"rig-sim ended ({rig.returncode})")
        mb = subprocess.run(["mbpoll", "-m", "tcp", "-a", "1", "-t", "4", "-r", "1", "-c", "1",
                             "-1", "-p", str(a.port), "127.0.0.1"],
                            capture_output=True, text=True, timeout=30)
        if mb.returncode != 0 or "[1]:" not in mb.stdout:
            problems.append("rig-sim no longer answers mbpoll")
    finally:
        rig.kill()
        rig.wait()
    for p in problems:
        print("FAILED:", p)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
