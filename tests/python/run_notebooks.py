#!/usr/bin/python3
"""Runs examples/board_script.py and executes every notebook in examples/
(nbclient, the python3 kernel)
against a piezod on the simulated rig that it starts, with a `piezo run`
log for the identification notebook; writes the executed notebooks (with
their plots) to OUT and exits non-zero on the first cell that fails, or
when a notebook's long work shows no progress under its cell.
usage: run_notebooks.py EXAMPLES_DIR OUT_DIR  (PIEZOD_BINARY, PIEZO_BINARY,
PIEZO_SOURCE_DIR and PYTHONPATH as CTest sets them)"""

import glob
import os
import subprocess
import sys
import time

import nbformat
from nbclient import NotebookClient
from nbclient.exceptions import CellExecutionError

examples, out = sys.argv[1], sys.argv[2]
source = os.environ["PIEZO_SOURCE_DIR"]
sys.path.insert(0, os.path.join(source, "tests", "support"))
import peers  # noqa: E402

# What a reader sees under the cells of long work: its progress (the
# study's runs counted on the kernel's sys.stderr).
PROGRESS = {"01-simulate-sweep-sobol.ipynb": ["sweep: 24/24 points done", "runs done"]}


def stderr_text(nb):
    return "".join(o.get("text", "") for cell in nb.cells for o in cell.get("outputs", [])
                   if o.get("output_type") == "stream" and o.get("name") == "stderr")


os.makedirs(out, exist_ok=True)
board, address = peers.start_piezod(os.environ["PIEZOD_BINARY"],
                                    os.path.join(source, "configs", "piezod-sim.toml"),
                                    os.path.join(out, "piezod.err"))
# A board of three axes, for the notebook that moves several.
axes_board, axes_address = peers.start_piezod(os.environ["PIEZOD_BINARY"],
                                              os.path.join(source, "configs", "three-axes.toml"),
                                              os.path.join(out, "piezod-axes.err"))
run_dir = os.path.join(out, "runs", "first")
subprocess.run(["rm", "-rf", run_dir])
subprocess.run([os.environ["PIEZO_BINARY"], "run", "--config",
                os.path.join(source, "configs", "sim.toml"), "--set", "run.clock=virtual",
                "--duration", "1", "--out", run_dir], check=True, stdout=subprocess.DEVNULL)
os.environ["PIEZO_BOARD"], os.environ["PIEZO_RUN"] = address, os.path.abspath(run_dir)
os.environ["PIEZO_AXES_BOARD"] = axes_address
# The kernels run in OUT: the package's path must not be relative.
os.environ["PYDEVD_DISABLE_FILE_VALIDATION"] = "1"  # the kernel's debugger notice
os.environ["PYTHONPATH"] = os.pathsep.join(
    os.path.abspath(p) for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p)
failed = []
try:
    script = subprocess.run([sys.executable, os.path.join(examples, "board_script.py"), address],
                            capture_output=True, text=True, timeout=120)
    print(f"board_script.py: {'ok' if script.returncode == 0 else 'FAILED'}\n{script.stdout}"
          f"{script.stderr}", flush=True)
    if script.returncode != 0:
        failed.append("board_script.py")
    for path in sorted(glob.glob(os.path.join(examples, "*.ipynb"))):
        name = os.path.basename(path)
        nb = nbformat.read(path, as_version=4)
        started = time.monotonic()
        try:
            NotebookClient(nb, timeout=300, kernel_name="python3",
                           resources={"metadata": {"path": out}}).execute()
            missing = [p for p in PROGRESS.get(name, []) if p not in stderr_text(nb)]
            print(f"{name}: {'FAILED, no progress shown: ' + str(missing) if missing else 'ok'}"
                  f" in {time.monotonic() - started:.1f} s", flush=True)
            if missing:
                failed.append(name)
        except CellExecutionError as e:
            print(f"{name}: FAILED\n{e}", flush=True)
            failed.append(name)
        nbformat.write(nb, os.path.join(out, name))
finally:
    for process in (board, axes_board):
        process.terminate()
        process.wait(10)
sys.exit(1 if failed else 0)
