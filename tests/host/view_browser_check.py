#!/usr/bin/python3
"""The web view in a real browser: headless Chromium (Debian's chromium and
chromium-driver, driven by python3-selenium) opens the live page of a run
and sees the angle readout and the plot advance; a request without the token,
and one from another site, are refused; after the run the catalogue lists it
and its page draws its plots. Saves screenshots of both pages. The Move
button of `piezo view --rig` runs a move shown in its panel; ten tabs share
one stream, show what /api/live.json shows, and the E-stop in the tenth acts.
A group move of three axes draws a block of plots per axis, and the Stop of
one axis ends that axis alone.

Usage: view_browser_check.py PIEZO SCREENSHOT_DIR   (exit 77: no browser here)
"""
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

SOURCE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(SOURCE, "tests", "support"))
import peers  # noqa: E402
from peers import free_port, start_piezod  # noqa: E402


STARTED = time.monotonic()


def say(*what):
    """A line of progress with the test's time: a slow part shows in the log."""
    print(f"[{time.monotonic() - STARTED:6.1f} s]", *what, flush=True)


def check(condition, what):
    if not condition:
        say("FAILED:", what)
        sys.exit(1)


def post(url, headers):
    request = urllib.request.Request(url, data=b"", headers=headers, method="POST")
    try:
        with urllib.request.urlopen(request, timeout=30) as r:
            return r.status, json.load(r)
    except urllib.error.HTTPError as e:
        return e.code, json.load(e)


# How long a watched run may last: the test ends it long before (Stop or
# E-stop from the page); the bound only ends a run whose test has died.
RUN_S = 900


def wait_until(condition, what, seconds=120):
    deadline = time.time() + seconds
    while time.time() < deadline:
        if condition():
            return
        time.sleep(0.1)
    check(False, f"{what} (waited {seconds} s)")


def wait_for_banner(path, deadline):
    while time.time() < deadline:
        with open(path) as f:
            m = re.search(r"live view: (http://\S+?)(\?token=([0-9a-f]+))? ", f.read())
        if m:
            return m.group(1), m.group(3)
        time.sleep(0.05)
    check(False, "the view's banner")


def browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1280,1400",
                "--disable-dev-shm-usage",
                # Ten live tabs: Chromium slows the timers and rendering of
                # tabs in the background, and a throttled tab shows no
                # updates; these keep every tab running as the foreground.
                "--disable-background-timer-throttling",
                "--disable-backgrounding-occluded-windows",
                "--disable-renderer-backgrounding",
                "--disable-features=IntensiveWakeUpThrottling"):
        options.add_argument(arg)
    options.binary_location = shutil.which("chromium")
    driver = webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=options)
    # A renderer busy with ten live pages on a loaded machine can take long
    # to answer a script; a slow answer is waited for, not a failure.
    driver.set_script_timeout(120)
    return driver


def read_in(driver, tab, script):
    """A tab's value, with that tab in the foreground; None when its
    renderer did not answer in time (busy: the caller looks again)."""
    from selenium.common.exceptions import TimeoutException

    driver.switch_to.window(tab)
    try:
        return driver.execute_script(script)
    except TimeoutException:
        return None


def wait_for_updates(driver, tabs, count, stall_s=90, limit_s=400):
    """Waits until every tab has shown `count` updates. Bounded by progress:
    fails when no tab's count has grown for `stall_s` seconds, or after a
    generous `limit_s` in all; a loaded machine only makes it slower."""
    seen = {tab: 0 for tab in tabs}
    start = progress = time.time()
    while True:
        for tab in tabs:
            if seen[tab] >= count:
                continue
            n = read_in(driver, tab, "return window.piezoView.updates")
            if n is not None and n > seen[tab]:
                seen[tab], progress = n, time.time()
        if all(n >= count for n in seen.values()):
            return time.time() - start
        now = time.time()
        check(now - progress < stall_s and now - start < limit_s,
              f"every tab shows {count} updates: {list(seen.values())} after {now - start:.0f} s, "
              f"the last progress {now - progress:.0f} s ago")
        time.sleep(0.2)


def main():
    piezo, shots, piezod = sys.argv[1], sys.argv[2], sys.argv[3]
    if not (shutil.which("chromium") and shutil.which("chromedriver")):
        print("chromium or chromedriver missing: scripts/setup.sh installs them")
        sys.exit(77)
    os.makedirs(shots, exist_ok=True)
    work = tempfile.mkdtemp(prefix="piezo-view-")
    runs = os.path.join(work, "runs")
    # The browser first: on a loaded machine (a sanitizer build beside it)
    # its start takes seconds. The run lasts until the test stops it from
    # the page, so no wait here can outlast it.
    driver = browser()
    say("browser started")
    port = free_port()
    err = os.path.join(work, "run.err")
    run = peers.spawn(
        [piezo, "run", "--config", os.path.join(SOURCE, "configs", "sim.toml"), "--duration",
         str(RUN_S), "--view", f"127.0.0.1:{port}", "--control", "--json", "--out",
         os.path.join(runs, "r1")],
        stdout=subprocess.PIPE, stderr=open(err, "w"), text=True)
    try:
        url, token = wait_for_banner(err, time.time() + 60)
        check(token, "a token with --control")
        driver.get(f"{url}?token={token}")
        say("live page opened")
        wait_for_updates(driver, [driver.current_window_handle], 3)
        first = driver.execute_script("return [window.piezoView.t, window.piezoView.points]")
        angle_first = driver.find_element("id", "angle").text
        # Two updates later (at 4 a second), at least a second of run time on.
        wait_until(lambda: driver.execute_script("return window.piezoView.t") > first[0] + 1.0,
                   "the run time advances")
        second = driver.execute_script("return [window.piezoView.t, window.piezoView.points]")
        angle_second = driver.find_element("id", "angle").text
        # The live window keeps 400 to 800 columns of min and max: when the
        # run's length passes 400 columns the columns widen twice and their
        # count halves (at 5 s into the run, say). Between the two looks the
        # plot keeps about as many points, or at least 400 columns' worth.
        check(second[1] > 0 and second[1] >= 0.9 * min(first[1], 800),
              f"the angle plot holds points: {first} -> {second}")
        check(angle_second != angle_first, f"the angle readout advances: {angle_first} -> {angle_second}")
        # The loop-timing histograms come apart from the status, when they
        # change and at most about once a second: the plot still gets them.
        wait_until(lambda: driver.execute_script("return window.piezoView.timing_bins") > 0,
                   "the loop-timing plot has bins")
        driver.save_screenshot(os.path.join(shots, "view_live.png"))

        # Control needs the token, from this page's own origin.
        status, body = post(url + "api/estop", {})
        check(status == 403 and "token" in body["error"], f"no token: {status} {body}")
        status, body = post(url + "api/estop", {"X-Piezo-Token": token,
                                                "Origin": "http://evil.example"})
        check(status == 403 and "cross-site" in body["error"], f"cross-site: {status} {body}")
        # The page's Stop ends the run: ramped to 0 V, interrupted, no fault
        # (the refused e-stops changed nothing).
        driver.find_element("id", "stop").click()
        wait_until(lambda: driver.find_element("id", "control-result").text == "stop sent",
                   "the page's Stop answered")
        out, _ = run.communicate(timeout=120)
        summary = json.loads(out)
        check(summary["stop_cause"] == "interrupted",
              f"the run ended by the page's Stop, not an e-stop: {summary['status']} "
              f"({summary['stop_cause']})")
        say("live:", first, second, angle_first, angle_second, "ended", summary["status"])

        # The catalogue, read-only: the run is listed and its page draws.
        port2 = free_port()
        err2 = os.path.join(work, "view.err")
        view = peers.spawn([piezo, "view", "--runs", runs, "--listen", f"127.0.0.1:{port2}"],
                                stderr=open(err2, "w"))
        try:
            url2, token2 = wait_for_banner(err2, time.time() + 60)
            check(token2 is None, "read-only without --control")
            status, body = post(url2 + "api/stop", {"X-Piezo-Token": "anything"})
            check(status == 403 and "read-only" in body["error"], f"read-only: {status} {body}")
            driver.get(url2 + "runs")
            deadline = time.time() + 60
            while time.time() < deadline and not driver.find_elements("css selector", "#runs tbody tr"):
                time.sleep(0.1)
            rows = driver.find_elements("css selector", "#runs tbody tr")
            check(len(rows) == 1 and "r1" in rows[0].text and summary["status"] in rows[0].text,
                  "the catalogue lists the run: " + " | ".join(r.text for r in rows))
            rows[0].find_element("link text", "r1").click()
            deadline = time.time() + 60
            while time.time() < deadline and len(driver.find_elements("css selector", ".uplot")) < 4:
                time.sleep(0.1)
            check(len(driver.find_elements("css selector", ".uplot")) == 4, "the run page's plots")
            check("[drive]" in driver.find_element("id", "config").text, "the run's config")
            driver.save_screenshot(os.path.join(shots, "view_run.png"))
            with urllib.request.urlopen(url2 + "files/r1/run.h5", timeout=30) as r:
                check(r.read(8) == b"\x89HDF\r\n\x1a\n", "run.h5 downloads")
        finally:
            view.terminate()
            view.wait(timeout=10)
        say("ok", len(rows), "run listed; screenshots in", shots)
        move_from_the_page(driver, piezo, piezod, work)
        group_move_on_the_page(driver, piezo, work, shots)
        scan_on_the_page(driver, piezo, work, shots)
        many_tabs(driver, piezo, work)
    finally:
        if driver:
            driver.quit()
        if run.poll() is None:
            run.kill()
        shutil.rmtree(work, ignore_errors=True)


def scan_on_the_page(driver, piezo, work, shots):
    """`piezo scan` with --view, in real time (the axis calibrated first, on
    the virtual clock): the page marks each trigger pulse on the angle
    plot, as many as the run logged."""
    config = os.path.join(SOURCE, "configs", "sim.toml")
    calibration = os.path.join(work, "scan-calibration.json")
    subprocess.run([piezo, "calibrate", "--config", config, "--set", "run.clock=virtual", "--set",
                    f"piezod.calibration_file={calibration}", "--out",
                    os.path.join(work, "scan-calibration")], check=True, capture_output=True)
    port = free_port()
    err = os.path.join(work, "scan.err")
    run = peers.spawn(
        [piezo, "scan", "--config", config, "--set", f"piezod.calibration_file={calibration}",
         "--from", "0.005", "--to", "0.045", "--velocity", "0.01", "--trigger-step", "0.004",
         "--view", f"127.0.0.1:{port}", "--json", "--out", os.path.join(work, "scan")],
        stdout=subprocess.PIPE, stderr=open(err, "w"), text=True)
    try:
        url, _ = wait_for_banner(err, time.time() + 60)
        driver.get(url)

        def marked():
            axes = driver.execute_script("return window.piezoView.axes") or []
            return axes[0].get("triggers", 0) if axes else 0

        wait_until(lambda: marked() >= 3, "trigger pulses marked on the angle plot")
        driver.save_screenshot(os.path.join(shots, "view_scan.png"))
        out, _ = run.communicate(timeout=180)
        fired = json.loads(out)["scans"]["rotor"]["triggers"]["fired"]
        wait_until(lambda: marked() == fired, f"every pulse of the {fired} marked", seconds=30)
        # The page was sent the run's end before the view closed: how it ended.
        state = driver.execute_script("return document.getElementById('state').textContent")
        assert state == "ended: completed", state
        say("scan on the page:", marked(), "pulses marked of", fired, "; state:", state)
    finally:
        if run.poll() is None:
            run.kill()


def group_move_on_the_page(driver, piezo, work, shots):
    """`piezo move` of three axes with --view --control, in real time: the
    page shows each axis's own plots (four each) advancing, and its Stop
    button for phi ends phi alone (interrupted) while theta and chi arrive.
    phi's target is far (some five minutes of steps; under load a target of
    1 rad was reached in 76 s, before the page was clicked): a loaded machine's
    browser may take tens of seconds to show the page, and phi must still
    be moving then."""
    port = free_port()
    err = os.path.join(work, "group.err")
    run = peers.spawn(
        [piezo, "move", "--config", os.path.join(SOURCE, "configs", "three-axes.toml"), "--set",
         "run.clock=realtime", "--to", "theta=0.004", "--to", "phi=-6.0", "--to", "chi=0.004",
         "--timeout", str(RUN_S), "--view", f"127.0.0.1:{port}", "--control", "--json", "--out",
         os.path.join(work, "group")],
        stdout=subprocess.PIPE, stderr=open(err, "w"), text=True)
    try:
        url, token = wait_for_banner(err, time.time() + 60)
        driver.get(f"{url}?token={token}")

        def axes():
            return driver.execute_script("return window.piezoView.axes") or []

        wait_until(lambda: [a["name"] for a in axes()] == ["theta", "phi", "chi"] and
                   all(a["points"] > 10 for a in axes()), "a plot per axis, each with points")
        first = {a["name"]: a["last"] for a in axes()}
        wait_until(lambda: next(a["last"] for a in axes() if a["name"] == "phi") < first["phi"] - 0.002,
                   "phi's angle advances on its own plot")
        check(len(driver.find_elements("css selector", "#axes .uplot")) == 12, "four plots per axis")
        driver.save_screenshot(os.path.join(shots, "view_group.png"))
        driver.find_element("id", "stop-phi").click()
        wait_until(lambda: driver.find_element("id", "control-result").text == "stop sent",
                   "the page's Stop of phi answered")
        out, _ = run.communicate(timeout=120)
        moves = {m["axis"]: m for m in json.loads(out)["moves"]}
        check(moves["phi"]["stop_cause"] == "interrupted", f"phi stopped from the page: {moves['phi']}")
        check(moves["theta"]["on_target"] and moves["chi"]["on_target"],
              f"the others arrived: {moves['theta']} {moves['chi']}")
        say("group move on the page: phi stopped at", moves["phi"]["position_rad"], "rad")
    finally:
        if run.poll() is None:
            run.kill()


def many_tabs(driver, piezo, work):
    """Ten live tabs in one browser share one stream (a browser keeps six
    connections to a host: a stream per tab left none for the E-stop), each
    plot shows what /api/live.json shows, and the E-stop in the last tab
    ends the run at once. Under a sanitizer build (PIEZO_BROWSER_TABS), seven:
    still more than the browser's six connections, and ten tabs of a
    sanitized server took six minutes to show their updates."""
    tabs_wanted = int(os.environ.get("PIEZO_BROWSER_TABS", "10"))
    port = free_port()
    err = os.path.join(work, "tabs.err")
    # The rig's own stall checks are not what this watches: a machine busy
    # with many tabs must not end the run by a late sensor reading.
    run = peers.spawn(
        [piezo, "run", "--config", os.path.join(SOURCE, "configs", "sim.toml"), "--duration",
         str(RUN_S), "--set", "safety.sensor_stale_s=5", "--view", f"127.0.0.1:{port}",
         "--control", "--json", "--out", os.path.join(work, "tabs")],
        stdout=subprocess.PIPE, stderr=open(err, "w"), text=True)
    try:
        url, token = wait_for_banner(err, time.time() + 60)
        tabs = []
        for i in range(tabs_wanted):
            if i:
                driver.switch_to.new_window("tab")
            driver.get(f"{url}?token={token}")
            tabs.append(driver.current_window_handle)
        say(f"{tabs_wanted} tabs opened")
        took = wait_for_updates(driver, tabs, 2)
        say(f"{tabs_wanted} tabs showed two updates each within {took:.1f} s")
        if run.poll() is not None:
            with open(err) as f:
                check(False, f"the run is still running: it exited {run.returncode}: "
                             f"{f.read()[-2000:]} {run.stdout.read()[-2000:]}")
        pages = driver.execute_script("return window.piezoView.pages")
        check(pages == 1, f"{tabs_wanted} tabs, one stream: the view serves {pages}")
        # The plot's points, sent as what changed, are the snapshot's. While
        # the run is short its columns widen now and then (and the window is
        # sent again): compared at one width.
        for _ in range(40):
            last, measured, width = driver.execute_script(
                "const v = window.piezoView; return [v.last, v.measured, v.column_s]")
            with urllib.request.urlopen(url + "api/live.json", timeout=30) as r:
                live = json.load(r)
            if live["column_s"] == width:
                break
            time.sleep(0.25)
        check(live["column_s"] == width, f"the page's columns {width} s, the snapshot's {live['column_s']} s")
        snapshot = live["axes"][0]["measured"]
        held = {(t, y) for t, y in zip(measured["t"], measured["y"]) if t >= snapshot["t"][0]}
        shown = {(t, y) for t, y in zip(snapshot["t"], snapshot["y"]) if t <= last[0]}
        check(tuple(last) in shown, f"the plot's last point {last} is in /api/live.json")
        check(held == shown, f"the plot holds the snapshot's points: {len(held ^ shown)} differ "
                             f"of {len(shown)}")
        start = time.time()
        driver.find_element("id", "estop").click()
        result = ""
        while time.time() < start + 60 and "estop" not in result:
            result = driver.find_element("id", "control-result").text
            time.sleep(0.05)
        took = time.time() - start
        check(result == "estop sent", f"the E-stop in the last tab answered: {result!r}")
        out, _ = run.communicate(timeout=120)
        summary = json.loads(out)
        check("estop" in summary["stop_cause"], f"the run ended by the e-stop: {summary}")
        say(f"{tabs_wanted} tabs, one stream; e-stop from the last answered in {took:.2f} s; run "
              f"{summary['status']} ({summary['stop_cause']}); {len(shown)} points as the snapshot's")
        for tab in tabs[1:]:
            driver.switch_to.window(tab)
            driver.close()
        driver.switch_to.window(tabs[0])
    finally:
        if run.poll() is None:
            run.kill()


def move_from_the_page(driver, piezo, piezod, work):
    """`piezo view --rig --control` against the simulated board whose config
    limits V0 to 60 V: the page's move form is the board's dictionary; 70 V
    is refused on the page naming the board's limit, and nothing reaches the
    board; a move within it runs on the board, whose state shows in the move
    panel while the button keeps its label."""
    board, address = start_piezod(piezod, os.path.join(SOURCE, "configs", "piezod-sim.toml"),
                                  os.path.join(work, "piezod.err"),
                                  sets=("drive.V_max=60", "drive.V0=50"))
    err = os.path.join(work, "rig-view.err")
    view, url, token = None, None, None
    # The view's hello to a board that is still starting (a loaded machine)
    # can go unanswered within its 2 s: it says so and exits; started again.
    for _ in range(5):
        port = free_port()
        view = peers.spawn([piezo, "view", "--rig", address,
                                 "--control", "--listen", f"127.0.0.1:{port}"],
                                stderr=open(err, "w"))
        deadline = time.time() + 60
        while time.time() < deadline and view.poll() is None and url is None:
            with open(err) as f:
                m = re.search(r"live view: (http://\S+?)(\?token=([0-9a-f]+))? ", f.read())
            if m:
                url, token = m.group(1), m.group(3)
            time.sleep(0.05)
        if url:
            break
        view.kill()
        view.wait()
        time.sleep(1)
    with open(err) as f:
        check(url is not None, "the rig view's banner: " + f.read())

    def requests():
        return json.loads(subprocess.run([piezo, "status", "--rig", address, "--json"],
                                         capture_output=True, text=True).stdout)["requests"]

    def fill(name, value):
        field = driver.find_element("id", "move-" + name)
        field.clear()
        field.send_keys(value)

    try:
        driver.get(f"{url}?token={token}")
        deadline = time.time() + 30
        while time.time() < deadline and not driver.find_elements("id", "move-target_rad"):
            time.sleep(0.1)
        fields = [e.get_attribute("id") for e in driver.find_elements("css selector", "#move-form [id^=move-]")]
        check(fields[:2] == ["move-target_rad", "move-tolerance_rad"] and "move-approach" in fields
              and "move-V0" in fields and "move-lease_s" in fields,
              "the move form has a field for every argument the board declares: " + repr(fields))
        fill("target_rad", "0.0005")
        fill("V0", "70")
        button = driver.find_element("id", "move-button")
        button.click()
        result = driver.find_element("id", "control-result").text
        check("not sent" in result and "the board's V_max is 60 V" in result,
              "70 V refused on the page, naming the board's limit: " + repr(result))
        check(requests()["move_to"] == 0, "nothing reached the board: " + repr(requests()))
        fill("V0", "50")
        button.click()
        panel = ""
        deadline = time.time() + 60
        while time.time() < deadline and "on_target" not in panel:
            panel = driver.find_element("id", "move-panel").text
            time.sleep(0.1)
        check("move " in panel and "on_target" in panel,
              "the move panel shows the board's move state: " + repr(panel))
        check(button.text == "Move", "the button keeps its label: " + repr(button.text))
        check(requests()["move_to"] == 1, "one move_to for the page's move: " + repr(requests()))
        say("move from the page:", panel)
    finally:
        view.terminate()
        view.wait(timeout=10)
        board.terminate()
        board.wait(timeout=10)


if __name__ == "__main__":
    main()
