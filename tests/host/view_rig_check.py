#!/usr/bin/python3
"""`piezo view --rig` against a real piezod on loopback: the live feed
follows the board's run, a move-to from the page (with the token) runs on the
board until on target and keeps its lease, a request without the token is
refused, and e-stop from the page latches the board's fault. Then the board
restarts on its port: the view takes it for a new board (its moves are
taken, not refused for the old board's identity).

Usage: view_rig_check.py PIEZOD PIEZO
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


def check(condition, what):
    if not condition:
        print("FAILED:", what)
        sys.exit(1)


def post(url, body, headers):
    data = json.dumps(body).encode()
    request = urllib.request.Request(url, data=data, method="POST",
                                     headers={"Content-Type": "application/json", **headers})
    try:
        with urllib.request.urlopen(request, timeout=10) as r:
            return r.status, json.load(r)
    except urllib.error.HTTPError as e:
        return e.code, json.load(e)


def get(url):
    with urllib.request.urlopen(url, timeout=10) as r:
        return json.load(r)


def wait_for(predicate, seconds, what):
    deadline = time.time() + seconds
    while time.time() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(0.1)
    check(False, what)


def main():
    piezod, piezo = sys.argv[1], sys.argv[2]
    work = tempfile.mkdtemp(prefix="piezo-view-rig-")
    view_port = free_port()
    board, address = start_piezod(piezod, os.path.join(SOURCE, "configs", "piezod-sim.toml"),
                                  os.path.join(work, "piezod.log"))
    err = os.path.join(work, "view.err")
    view = None
    url = None
    try:
        view = peers.spawn([piezo, "view", "--rig", address, "--listen", f"127.0.0.1:{view_port}",
                                 "--control", "--runs", work], stderr=open(err, "w"))
        m = wait_for(lambda: re.search(r"live view: (http://\S+?)\?token=([0-9a-f]+)", open(err).read()),
                     10, "the view's banner")
        url, token = m.group(1), m.group(2)

        status, body = post(url + "api/move", {"target_rad": 0.002}, {})
        check(status == 403 and "token" in body["error"], f"no token: {status} {body}")
        def requests():
            return json.loads(subprocess.run([piezo, "status", "--rig", address, "--json"],
                                             capture_output=True, text=True).stdout)["requests"]
        # Beyond the board's limit: refused by the view from the board's
        # dictionary, naming the limit; the board never sees it.
        status, body = post(url + "api/move", {"target_rad": 0.002, "V0": 90},
                            {"X-Piezo-Token": token})
        check(status == 409 and "the board's V_max is 80 V" in body["error"],
              f"a move beyond V_max: {status} {body}")
        check(requests()["move_to"] == 0, f"the refused move was not sent: {requests()}")
        # Every declared field travels, as the page gave it.
        asked = {"target_rad": 0.002, "tolerance_rad": 30e-6, "settle_s": 0.15, "timeout_s": 25.0,
                 "hold_s": 0.0, "protect": True, "stall_steps": 3, "approach": "forward",
                 "V0": 70.0, "C_dr": 0.95, "e_dr": 0.789}
        status, body = post(url + "api/move", asked, {"X-Piezo-Token": token})
        check(status == 200 and body["ok"], f"move-to: {status} {body}")
        sent = {key: body["reply"]["moves"][0].get(key) for key in asked}
        check(sent == asked, f"the board took every field the page sent: {sent}")

        def on_target():
            live = get(url + "api/live.json")
            board_status = live["status"].get("board", {})
            summary = board_status.get("summary", {})
            return next((a.get("move") for a in summary.get("axes", [])), None)
        move = wait_for(on_target, 30, "the move ends (its lease kept by the view)")
        check(move.get("on_target"), f"the move came on target: {move}")
        live = get(url + "api/live.json")
        check(len(live["axes"][0]["measured"]["t"]) > 50, "the live feed followed the board's run")
        check(abs(move["error_rad"]) <= 30e-6, f"on target: {move}")
        check(requests()["move_to"] == 1 and requests()["configure"] == 0,
              f"one request for the move: {requests()}")

        status, body = post(url + "api/stop", {}, {"X-Piezo-Token": token})
        check(status == 409 and "only the client" in body["error"], f"stop of nothing: {status} {body}")
        status, body = post(url + "api/estop", {}, {"X-Piezo-Token": token})
        check(status == 200, f"e-stop: {status} {body}")
        state = json.loads(subprocess.run([piezo, "status", "--rig", address, "--json"],
                                          capture_output=True, text=True).stdout)
        check(state["fault"] == "estop", f"the board latched the e-stop: {state['fault']}")
        position = state["axes"][0]["position"]
        check(abs(position["position_rad"] - 0.002) < 30e-6, f"position: {position}")
        # The board restarts on its port: a new board, which the view meets
        # (hello and dictionary again) and moves.
        board.kill()
        board.wait()
        board = peers.restart_piezod(piezod, os.path.join(SOURCE, "configs", "piezod-sim.toml"),
                                     os.path.join(work, "piezod.log"), address)

        def moved_on_new_board():
            status, body = post(url + "api/move", {"target_rad": -0.001}, {"X-Piezo-Token": token})
            return status == 200 and body["ok"] and body
        wait_for(moved_on_new_board, 20, "a move from the page on the restarted board")
        again = wait_for(on_target, 30, "the move on the restarted board ends")
        check(again.get("on_target") and again["target_rad"] == -0.001,
              f"on target on the new board: {again}")
        print("ok", move["steps"], move["on_target_at_s"], move["error_rad"])
    except SystemExit:
        # What the board and the view said, for whoever reads a failure.
        for name in ("piezod.log", "view.err"):
            print(f"--- {name} (last lines)")
            print("".join(open(os.path.join(work, name)).readlines()[-15:]))
        print("--- live status:", get(url + "api/live.json")["status"] if view and url else None)
        raise
    finally:
        for p in (view, board):
            if p and p.poll() is None:
                p.terminate()
                p.wait(timeout=10)
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
