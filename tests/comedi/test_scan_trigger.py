"""A fly scan's trigger on a DAQ card's digital output, in a qemu guest
(tests/comedi/scan-init.sh): `piezo scan` with tests/comedi/scan.toml
drives the simulated motor and pulses data line 2 of qemu's parallel port
through the comedi backend (Linux's comedi_parport), while an independent
watcher in the guest (trigger_watch) records each rising edge the port's
data register shows. Its calibration is made here first,
on the same config with the simulated lines on the virtual clock. The
edges must match the log's pulses one to one: as many, in order, each at
its logged time.

CTest passes PIEZO_SOURCE_DIR, PIEZO_BINARY, PIEZO_MODULE_DIR (piezo's
module folder), TRIGGER_WATCH, GUEST_WORK and GUEST_KERNEL."""

import base64
import io
import json
import os
import shutil
import subprocess

import h5py
import numpy as np
import pytest

SOURCE = os.environ.get("PIEZO_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
CONFIG = os.path.join(SOURCE, "tests", "comedi", "scan.toml")
FROM, TO, STEP = 0.01, 0.05, 0.001  # as scan-init.sh asks


def guest_output(work):
    """What the guest wrote to its second serial port, by section."""
    parts, current = {}, None
    with open(os.path.join(work, "ttyS1.out"), "rb") as f:
        for line in f.read().decode("ascii", "replace").splitlines():
            line = line.strip()
            if line in ("summary", "log", "edges", "end"):
                current = parts.setdefault(line, [])
            elif current is not None:
                current.append(line)
    return {name: base64.b64decode("".join(lines)) for name, lines in parts.items()}


@pytest.fixture(scope="module")
def scanned():
    work = os.environ["GUEST_WORK"]
    os.makedirs(work, exist_ok=True)
    calibration = os.path.join(work, "calibration.json")
    shutil.rmtree(os.path.join(work, "calibration-run"), ignore_errors=True)
    if os.path.exists(calibration):
        os.remove(calibration)
    subprocess.run([os.environ["PIEZO_BINARY"], "calibrate", "--config", CONFIG,
                    "--set", "lines.backend=sim", "--set", "run.clock=virtual",
                    "--set", f"piezod.calibration_file={calibration}",
                    "--out", os.path.join(work, "calibration-run")],
                   check=True, capture_output=True)
    # piezo's modules: HDF5 for the log, and the rig's commands.
    modules = " ".join(f"{os.path.join(os.environ['PIEZO_MODULE_DIR'], m)}=/lib/piezo/{m}"
                       for m in ("libpiezo_h5.so", "libpiezo_rig_commands.so"))
    env = dict(os.environ, GUEST_MEMORY="768M",
               GUEST_FILES=f"{modules} {CONFIG}=/scan.toml "
                           f"{calibration}=/calibration.json "
                           f"{os.environ['TRIGGER_WATCH']}=/trigger_watch")
    guest = subprocess.run(
        [os.path.join(SOURCE, "tests", "qemu", "run-guest.sh"), "comedi-scan",
         os.path.join(SOURCE, "tests", "comedi", "scan-init.sh"), os.environ["PIEZO_BINARY"],
         work, os.environ["GUEST_KERNEL"], "comedi.comedi_num_legacy_minors=1"],
        env=env, capture_output=True, text=True)
    print(guest.stdout, guest.stderr)
    if guest.returncode == 77:
        pytest.skip(guest.stdout.strip().splitlines()[-1])
    assert guest.returncode == 0, guest.stdout
    out = guest_output(work)
    summary = json.loads(out["summary"])
    with h5py.File(io.BytesIO(out["log"])) as f:
        triggers = {name: f["axes/rotor/triggers"][name][()] for name in f["axes/rotor/triggers"]}
        t0_ns = int(f.attrs["board_t0_ns"])
    edges_ns = np.array([int(line) for line in out["edges"].decode().split()], dtype=np.int64)
    return summary, triggers, t0_ns, edges_ns


def test_the_scan_ends_done_with_its_pulses_logged(scanned):
    summary, triggers, _, _ = scanned
    assert summary["scanned"], summary
    account = summary["scans"]["rotor"]
    expected = int(np.floor((TO - FROM) / STEP + 1e-9)) + 1
    order = np.argsort(triggers["k"])
    assert list(triggers["k"][order]) == list(range(expected))
    assert account["triggers"]["fired"] == expected
    assert account["measured_velocity_rad_per_s"] == pytest.approx(0.02, rel=0.05)


def test_the_edges_on_the_output_match_the_logged_pulses_one_to_one(scanned):
    _, triggers, t0_ns, edges_ns = scanned
    order = np.argsort(triggers["k"])
    logged_ns = t0_ns + np.round(triggers["edge_s"][order] * 1e9).astype(np.int64)
    assert len(edges_ns) == len(logged_ns), (edges_ns, logged_ns)
    # Each edge seen by the watcher after the line rose (it polls every
    # 200 us; under emulation it may wake late), never before.
    lag_ms = (edges_ns - logged_ns) / 1e6
    print(f"edges seen {np.median(lag_ms):.2f} ms after their logged time (median), "
          f"{lag_ms.max():.2f} ms at most")
    assert np.all(lag_ms > -1.0), lag_ms
    assert np.all(lag_ms < 50.0), lag_ms
