#!/usr/bin/python3
"""Bench: what the live view costs a run. The same real-time run on the
simulated rig, three ways: without the view, with the view serving nobody,
and with the live page open in headless Chromium (which shares the machine).
Prints each run's loop health and the CPU time of the `piezo` process (the
host, the in-process board and the web server together). Figures, not
assertions: shared machines are noisy, so each way runs REPEATS times.

Usage: bench_view.py PIEZO [SECONDS] [REPEATS]
"""
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

SOURCE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(SOURCE, "tests", "host"))
from view_browser_check import browser, free_port  # noqa: E402


def one_run(piezo, seconds, work, view, with_browser):
    out_dir = tempfile.mkdtemp(dir=work)
    shutil.rmtree(out_dir)
    args = [piezo, "run", "--config", os.path.join(SOURCE, "configs", "sim.toml"), "--duration",
            str(seconds), "--json", "--out", out_dir]
    if view:
        args += ["--view", f"127.0.0.1:{free_port()}"]
    err = os.path.join(work, "err.txt")
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=open(err, "w"), text=True)
    driver = None
    updates = 0
    try:
        if with_browser:
            deadline = time.time() + 20
            url = None
            while time.time() < deadline and not url:
                m = re.search(r"live view: (http://\S+?) ", open(err).read())
                url = m.group(1) if m else None
                time.sleep(0.05)
            driver = browser()
            driver.get(url)
        out = proc.stdout.read()
        if driver:
            updates = driver.execute_script("return window.piezoView.updates")
        _, status, usage = os.wait4(proc.pid, 0)
    finally:
        if driver:
            driver.quit()
    summary = json.loads(out)
    return summary, usage.ru_utime + usage.ru_stime, updates


def main():
    piezo = sys.argv[1]
    seconds = float(sys.argv[2]) if len(sys.argv) > 2 else 10.0
    repeats = int(sys.argv[3]) if len(sys.argv) > 3 else 2
    work = tempfile.mkdtemp(prefix="piezo-bench-view-")
    print(f"{seconds:g} s real-time runs on the simulated rig, {os.cpu_count()} cores")
    print(f"{'way':<22} {'drive overruns':>14} {'missed':>7} {'dropped':>7} {'p99 us':>7} "
          f"{'max us':>8} | {'sensor overruns':>15} {'dropped':>7} | {'piezo CPU s':>11} {'page updates':>12}")
    for label, view, with_browser in (("no view", False, False), ("view, no page open", True, False),
                                      ("view, page open", True, True)):
        for _ in range(repeats):
            s, cpu, updates = one_run(piezo, seconds, work, view, with_browser)
            d, a = s["drive"], s["sensor"]
            print(f"{label:<22} {d['overruns']:>14} {d['missed_cycles']:>7} {d['dropped']:>7} "
                  f"{d['period_error_us']['p99']:>7.0f} {d['period_error_us']['max']:>8.0f} | "
                  f"{a['overruns']:>15} {a['dropped']:>7} | {cpu:>11.2f} {updates:>12}")
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
