#!/usr/bin/python3
"""An independent piezod client, written from docs/protocol.md alone
(python3-zmq, python3-msgpack): calibrate, then move with the calibration.
A calibration that does not hold together is refused naming its key; a
second client can neither calibrate during the run nor install one; the
board's calibration is in hello and status; a move uses its fastest
frequency and comes on target; a tolerance below its noise floor is refused
up front. Prints "ok" and facts; exits non-zero on any mismatch.
usage: calibrate_client.py tcp://127.0.0.1:PORT"""
import sys
import time

import msgpack
import zmq

address = sys.argv[1]
host, port = address.rsplit(":", 1)
ctx = zmq.Context()
cmd = ctx.socket(zmq.DEALER)
cmd.connect(address)
other = ctx.socket(zmq.DEALER)  # a second client, which controls nothing
other.connect(address)
sub = ctx.socket(zmq.SUB)
sub.connect(f"{host}:{int(port) + 1}")
for topic in (b"state", b"health"):
    sub.setsockopt(zmq.SUBSCRIBE, topic)
next_id = 0


def call(name, socket=None, **args):
    global next_id
    socket = socket or cmd
    next_id += 1
    socket.send(msgpack.packb({"id": next_id, "cmd": name, "args": args}))
    if not socket.poll(5000):
        sys.exit(f"{name}: no reply")
    reply = msgpack.unpackb(socket.recv(), raw=False)
    assert reply["id"] == next_id, reply
    return reply


def check(condition, what):
    if not condition:
        sys.exit("FAILED: " + what)


def follow_run(run_id):
    """Renews the lease until the run's final state event; returns its
    summary and the largest calibration progress seen on the health topic."""
    progress = 0.0
    deadline = time.time() + 120
    while time.time() < deadline:
        if sub.poll(100):
            topic, body = sub.recv_multipart()
            event = msgpack.unpackb(body, raw=False)
            if topic == b"health":
                progress = max(progress, event.get("calibration_progress", 0.0))
            elif event["state"] in ("idle", "fault") and event.get("run") == run_id \
                    and "summary" in event:
                return event["summary"], progress
        # Only the samples acknowledged hold a virtual clock back; this
        # client logs nothing, so it acknowledges everything recorded.
        call("lease", drive_received=2**62)
    check(False, "the run ended")


hello = call("hello")["result"]
check(len(hello["axes"]) == 1 and "calibration" in hello["axes"][0],
      "hello says whether the board's axis is calibrated")
time.sleep(0.2)  # the subscription reaches the board first

# A calibration that does not hold together: refused by key, nothing kept.
bad = call("set_calibration", calibration={"version": 1, "V0": 80.0})
check(not bad["ok"] and bad["error"]["code"] == "bad_argument" and
      bad["error"]["key"].startswith("calibration."), "a bad calibration: " + str(bad))
unknown = call("calibrate", V0=80.0, steps=3)
check(unknown["error"]["code"] == "bad_argument" and unknown["error"]["key"] == "steps",
      "calibrate's arguments: " + str(unknown))

started = call("calibrate", lease_s=2.0)
check(started["ok"], "calibrate: " + str(started))
check(started["result"]["f_hz"][0] > 0 and started["result"]["steps_per_point"] >= 1,
      "calibrate says what it will do: " + str(started))
theirs = call("set_calibration", socket=other, calibration=None)
check(theirs["error"]["code"] == "not_controller", "another client's install: " + str(theirs))
summary, progress = follow_run(started["result"]["run"])
check(summary["cause"] == "completed", "the calibration completed: " + summary["cause"])
cal = summary["calibration"]
check(cal is not None, "a calibration: " + str(summary.get("calibration_error")))
# health comes every 250 ms of wall time, and a virtual-clock calibration
# may take under a second: how far it got by the last one varies.
check(progress > 0.0, f"progress was published: {progress}")
for key in ("noise_m", "rad_per_V", "fastest_f_hz", "smallest_tolerance_rad", "frequencies"):
    check(key in cal, f"the calibration has {key}")
status = call("status")["result"]
check(status["axes"][0]["calibrated"], "status says the axis is calibrated")
check(call("hello")["result"]["axes"][0]["calibration"] == cal,
      "hello reports the installed calibration")

# Installing it back as a client would (after adding a fitted model): the
# board recomputes what it derives and keeps the model.
cal["model"] = {"friction": "lugre", "parameters": {"F_N": 5e-3}}
installed = call("set_calibration", calibration=cal)
check(installed["ok"] and installed["result"]["calibration"]["model"]["parameters"]["F_N"] == 5e-3,
      "set_calibration: " + str(installed)[:300])
# This board has a calibration_file: the reply names it, and no error.
check(isinstance(installed["result"].get("saved_to"), str) and
      "save_error" not in installed["result"], "where the board keeps it: " +
      str({k: v for k, v in installed["result"].items() if k != "calibration"}))

too_fine = call("move_to", target_rad=1e-3, tolerance_rad=cal["smallest_tolerance_rad"] / 2)
check(too_fine["error"]["code"] == "out_of_limits" and
      too_fine["error"]["key"] == "tolerance_rad", "a tolerance below the noise: " + str(too_fine))

position = call("status")["result"]["axes"][0]["position"]["position_rad"] or 0.0
target = position - 20e-3
moved = call("move_to", target_rad=target, timeout_s=20.0, lease_s=2.0)
check(moved["ok"] and moved["result"]["moves"][0]["calibrated"] is True, "move_to: " + str(moved))
check(moved["result"]["moves"][0]["f"] == cal["fastest_f_hz"],
      "the move steps at the fastest frequency")
summary, _ = follow_run(moved["result"]["run"])
move = summary["axes"][0]["move"]
check(move["stop_cause"] == "on_target" and abs(move["error_rad"]) <= 25e-6,
      "on target: " + str(move))
print("ok", cal["fastest_f_hz"], cal["noise_m"], move["steps"], move["on_target_at_s"])
