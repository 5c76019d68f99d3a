#!/usr/bin/python3
"""Bench: what a user waits for a whole `piezo` process - start-up (the
dynamic loader, the libraries' own start-up, the command line) and the
model's paths as the CLI runs them - beside `piezod --version` (the board's
start-up). `--help` lists every command, so it loads the rig's commands'
module (ZeroMQ and the hardware libraries with it); a model command does
not. Each command runs REPEATS times; prints the fastest and the median
wall time, and `simulate`'s figures less the shortest simulation's (the
work on top of starting). Figures, not assertions.

Usage: bench_startup.py PIEZO PIEZOD [REPEATS]
"""
import os
import statistics
import subprocess
import sys
import tempfile
import time


def timed(args, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        subprocess.run(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
        times.append(time.perf_counter() - start)
    return min(times), statistics.median(times)


def libraries(binary):
    out = subprocess.run(["ldd", binary], capture_output=True, text=True).stdout
    return len([line for line in out.splitlines() if "=>" in line or line.strip().startswith("/")])


def main():
    piezo, piezod = sys.argv[1], sys.argv[2]
    repeats = int(sys.argv[3]) if len(sys.argv) > 3 else 30
    work = tempfile.mkdtemp(prefix="piezo-bench-startup-")
    true_min, _ = timed(["/bin/true"], repeats)
    print(f"whole processes, {repeats} runs each, {os.cpu_count()} cores; "
          f"/bin/true takes {true_min * 1e3:.2f} ms (the cost of starting any process from here)")
    module = os.path.join(os.path.dirname(piezo), "..", "lib", "piezo", "libpiezo_rig_commands.so")
    print(f"piezo links {libraries(piezo)} shared libraries, the rig commands' module "
          f"{libraries(module)}, piezod {libraries(piezod)}")
    print(f"{'command':<50} {'min ms':>8} {'median ms':>10} {'less start-up ms':>17}")
    rows = [
        ("piezo --help", [piezo, "--help"]),
        ("piezo status --help (a rig command)", [piezo, "status", "--help"]),
        ("piezo simulate --help (a model command)", [piezo, "simulate", "--help"]),
        ("piezo simulate --duration 0.001 --json", [piezo, "simulate", "--duration", "0.001", "--json"]),
        ("piezo simulate --duration 4.8 --json", [piezo, "simulate", "--duration", "4.8", "--json"]),
        ("piezo simulate --duration 4.8 --out t.csv (48,001)",
         [piezo, "simulate", "--duration", "4.8", "--out", os.path.join(work, "t.csv")]),
        ("piezo simulate --duration 4.8 --out t.h5 (48,001)",
         [piezo, "simulate", "--duration", "4.8", "--out", os.path.join(work, "t.h5")]),
        ("piezod --version", [piezod, "--version"]),
    ]
    start_up = None  # the shortest simulation's: starting, parsing, a 1 ms run
    for label, args in rows:
        fastest, median = timed(args, repeats)
        if "0.001" in label:
            start_up = fastest
        extra = (f"{(fastest - start_up) * 1e3:>17.2f}" if "4.8" in label else f"{'':>17}")
        print(f"{label:<50} {fastest * 1e3:>8.2f} {median * 1e3:>10.2f} {extra}")


if __name__ == "__main__":
    main()
