#!/usr/bin/python3
"""An independent piezod client, written from docs/protocol.md alone
(python3-zmq, python3-msgpack): hello and status, malformed, oversized and
unknown input (error replies, the daemon goes on, every other request is
answered), each command's arguments against the document's Commands table
(the board names what a command takes when it refuses one it does not),
a request beyond the board's limits, then a short run whose
samples arrive on the stream, a fetch from the recorder, steps that end on
their period's 0 V, a closed-loop move that a second client can neither
re-zero nor steer, and the zero. Prints "ok" and facts; exits non-zero on
any mismatch.
usage: protocol_client.py tcp://127.0.0.1:PORT"""
import os
import re
import struct
import sys
import time

import msgpack
import zmq

address = sys.argv[1]
host, port = address.rsplit(":", 1)
stream_address = f"{host}:{int(port) + 1}"

ctx = zmq.Context()
cmd = ctx.socket(zmq.DEALER)
cmd.connect(address)
sub = ctx.socket(zmq.SUB)
sub.connect(stream_address)
for topic in (b"drive", b"sensor", b"state", b"health"):
    sub.setsockopt(zmq.SUBSCRIBE, topic)
next_id = 0


def call(name, socket=None, **args):
    global next_id
    socket = socket or cmd
    next_id += 1
    socket.send(msgpack.packb({"id": next_id, "cmd": name, "args": args}))
    if not socket.poll(3000):
        sys.exit(f"{name}: no reply")
    reply = msgpack.unpackb(socket.recv(), raw=False)
    assert reply["id"] == next_id, reply
    return reply


other = ctx.socket(zmq.DEALER)  # a second client, which controls nothing
other.connect(address)


def check(condition, what):
    if not condition:
        sys.exit("FAILED: " + what)


def frame_header(body):
    magic, version, stream, first, count, record = struct.unpack_from("<4sHHQII", body)
    check(magic == b"PZSB" and version == 1, "frame magic/version")
    check(len(body) == 24 + count * record, "frame length")
    return stream, first, count, record


hello = call("hello")["result"]
check(hello["protocol"] == 6, "protocol version")
check(len(hello["axes"]) == 1 and hello["axes"][0]["r2_m"] > 0,
      "hello names its one axis's sensor radius: " + str(hello))
check("sensor" not in hello and "calibration" not in hello,
      "nothing of an axis at hello's top level: " + str(sorted(hello)))
limits = hello["limits"]
drive_period_ns = round(1e9 / hello["drive_rate_hz"])
status = call("status")["result"]
check(status["state"] == "idle", "idle at start: " + status["state"])

cmd.send(b"\xc1 not msgpack")
check(cmd.poll(3000), "reply to a malformed message")
bad = msgpack.unpackb(cmd.recv(), raw=False)
check(not bad["ok"] and bad["error"]["code"] == "malformed", "malformed -> error")
for request, key in (({"cmd": "hello"}, "id"), ({"id": 7}, "cmd")):
    cmd.send(msgpack.packb(request))
    check(cmd.poll(3000), f"reply to a request without {key}")
    reply = msgpack.unpackb(cmd.recv(), raw=False)
    check(not reply["ok"] and reply["error"]["code"] == "malformed",
          f"no {key} -> malformed: {reply}")

# An oversized request between two small ones, a second client's request
# among them: each answered, the big one too_large, in order.
cmd.send(msgpack.packb({"id": 901, "cmd": "clock"}))
cmd.send(msgpack.packb({"id": 902, "cmd": "clock", "args": {"pad": "x" * 70_000}}))
other.send(msgpack.packb({"id": 903, "cmd": "clock"}))
cmd.send(msgpack.packb({"id": 904, "cmd": "clock"}))
answers = {}
for _ in range(3):
    check(cmd.poll(3000), "every request around an oversized one is answered")
    reply = msgpack.unpackb(cmd.recv(), raw=False)
    answers[reply["id"]] = reply
check(other.poll(3000), "another client is answered during an oversized request")
check(msgpack.unpackb(other.recv(), raw=False)["ok"], "the other client's clock")
check(answers[901]["ok"] and answers[904]["ok"], "the small requests: " + str(answers))
check(answers[902]["error"]["code"] == "too_large", "70 kB -> too_large: " + str(answers[902]))

unknown_arg = call("configure", V0=60.0, f=10.0, duration_s=0.5, lease=1.0)
check(unknown_arg["error"]["code"] == "bad_argument" and unknown_arg["error"]["key"] == "lease",
      "an unknown argument is refused by name: " + str(unknown_arg))
unknown = call("fly")
check(unknown["error"]["code"] == "unknown_command", "unknown command")


def documented_commands():
    """The Commands table of docs/protocol.md: each cmd and the argument
    names its args column gives (parenthesised and bracketed notes and
    "as for `x`" left out; move_to's request from its own table)."""
    page = open(os.path.join(os.path.dirname(__file__), "..", "..", "docs", "protocol.md")).read()
    section = page.split("\n## Commands", 1)[1]
    table, request = section.split("### `move_to`'s arguments", 1)
    commands = {}
    for line in table.splitlines():
        cells = line.split(" | ")
        if not line.startswith("| `") or len(cells) < 3:
            continue
        name = cells[0].strip("| `")
        # Intervals first ("(0, 1]", "[0, 1)"): their brackets need not pair.
        args = re.sub(r"[\[(][^\[\]()]*,[^\[\]()]*[\])]", "", cells[1])
        while re.search(r"\([^()]*\)|\[[^\[\]]*\]", args):
            args = re.sub(r"\([^()]*\)|\[[^\[\]]*\]", "", args)
        args = re.sub(r"as for `[^`]*`", "", args)
        commands[name] = set(re.findall(r"`([A-Za-z_0-9]+)`", args))
    request = re.split(r"\n#{2,4} ", request, maxsplit=1)[0]
    commands["move_to"] |= set(re.findall(r"^\| `([A-Za-z_0-9]+)` \|", request, re.M))
    return commands


# Each command takes exactly the arguments the document lists: an argument
# it does not take is refused with the ones it does.
documented = documented_commands()
allowed_commands = re.search(r"\(allowed: (.*)\)", unknown["error"]["message"]).group(1)
check(set(allowed_commands.split(", ")) == set(documented),
      f"the board's commands {allowed_commands} are the document's {sorted(documented)}")
for name, args in documented.items():
    refused = call(name, not_documented=1)
    check(not refused["ok"] and refused["error"]["key"] == "not_documented",
          f"{name} refuses an argument it does not take: {refused}")
    taken = re.search(r"\(allowed: (.*)\)", refused["error"]["message"]).group(1)
    taken = set() if taken == "none" else set(taken.split(", "))
    check(taken == args, f"{name} takes {sorted(taken)}; the document lists {sorted(args)}")
# The board's dictionary says the same, and its V0 ends at the board's V_max.
dictionary = call("describe")["result"]
check(set(dictionary["commands"]) == set(documented),
      f"describe's commands {sorted(dictionary['commands'])}")
for name, args in documented.items():
    described = {a["name"] for a in dictionary["commands"][name]["args"]}
    check(described == args, f"describe: {name} takes {sorted(described)}")
V0 = next(a for a in dictionary["commands"]["configure"]["args"] if a["name"] == "V0")
check(V0["max"] == limits["V_max"] and V0["limit"] == "V_max" and V0["unit"] == "V",
      "describe: configure's V0 up to the board's V_max: " + str(V0))
check(dictionary["names"]["move_ends"][:2] == ["on_target", "timeout"],
      "describe: a move's ends: " + str(dictionary["names"]["move_ends"]))
beyond = call("configure", V0=limits["V_max"] + 10, f=10.0, duration_s=0.5)
check(beyond["error"]["code"] == "out_of_limits" and beyond["error"]["key"] == "V0",
      "beyond the limits: " + str(beyond))
wrong_type = call("configure", V0="high", f=10.0, duration_s=0.5)
check(wrong_type["error"]["key"] == "V0", "wrong type named")

sideways = call("configure", V0=60.0, f=10.0, duration_s=0.5, direction="sideways")
check(sideways["error"]["code"] == "bad_argument" and sideways["error"]["key"] == "direction",
      "an unknown direction is refused by name: " + str(sideways))
no_steps = call("step", count=0, V0=60.0, f=10.0)
check(no_steps["error"]["code"] == "out_of_limits" and no_steps["error"]["key"] == "count",
      "zero steps refused: " + str(no_steps))


def follow_run():
    """Streams a run to its end, renewing the lease; returns the final state
    event, the samples received per stream, the last drive record and the
    first and last good displacements."""
    received = {1: 0, 2: 0}
    last_drive = None
    displacement = []
    global move_updates
    move_updates = []
    deadline = time.time() + 30
    while time.time() < deadline:
        if sub.poll(100):
            topic, body = sub.recv_multipart()
            if topic == b"state":
                event = msgpack.unpackb(body, raw=False)
                if event["state"] in ("idle", "fault") and "summary" in event:
                    return event, received, last_drive, displacement
                continue
            if topic == b"health":
                event = msgpack.unpackb(body, raw=False)
                move_updates.extend(event.get("moves") or [])
                continue
            if topic not in (b"drive", b"sensor"):
                continue
            stream, first, count, record = frame_header(body)
            check(first == received[stream], f"stream {stream} in sequence")
            received[stream] += count
            if stream == 1 and count:
                last_drive = struct.unpack_from("<qdBB", body, 24 + (count - 1) * record)
            for i in range(count if stream == 2 else 0):
                _, _, d, st = struct.unpack_from("<qqdB", body, 24 + i * record)
                if st == 0:
                    displacement.append(d)
        call("lease", drive_received=received[1])
    check(False, "the run ended")


check(call("configure", V0=60.0, f=10.0, duration_s=0.5)["ok"], "configure")
time.sleep(0.2)
started = call("start", lease_s=1.0)
check(started["ok"], "start: " + str(started))
final, received, last_drive, _ = follow_run()
summary = final["summary"]
check(summary["cause"] == "completed", "cause " + summary["cause"])
check(received[1] == summary["samples"]["drive"], "every drive sample streamed")
check(received[2] == summary["samples"]["sensor"], "every sensor sample streamed")
check(last_drive[1] == 0.0 and last_drive[2] == 2, "the drive ends stopped at 0 V")
check((last_drive[0] - started["result"]["t0_ns"]) % drive_period_ns == 0,
      "the stopped record is on the deadline grid")
fetched = call("fetch", stream="sensor", first=10, count=5)["result"]["frame"]
stream, first, count, record = frame_header(fetched)
check(stream == 2 and first == 10 and count == 5, "fetch from the recorder")


def drive_records(n):
    """The run's n drive records from the recorder: (t_ns, V, phase)."""
    out = []
    while len(out) < n:
        frame = call("fetch", stream="drive", first=len(out),
                     count=min(n - len(out), 100000))["result"]["frame"]
        _, first, count, record = frame_header(frame)
        out += [struct.unpack_from("<qdB", frame, 24 + i * record) for i in range(count)]
    return out


# Steps end on their last period's 0 V: nothing ramps after the fast edge,
# forward and reverse ("count" 4.0 is the integer 4).
for direction in ("forward", "reverse"):
    stepped = call("step", count=4.0, direction=direction, V0=40.0, f=100.0, lease_s=1.0)
    check(stepped["ok"], "step: " + str(stepped))
    final, received, _, _ = follow_run()
    records = drive_records(final["summary"]["samples"]["drive"])
    ramped = [r for r in records if r[2] == 1 and r[1] != 0.0]
    if final["summary"]["drive"]["missed_cycles"] == 0:
        check(not ramped, f"{direction} steps ramp after their end: {len(ramped)} records, "
                          f"first {ramped[:1]}")
    else:
        # Missed deadlines left the drive behind the sawtooth (the document:
        # it catches up at the slew limit): it reaches 0 V at that limit too.
        per_record = limits["slew_V_per_s"] / hello["drive_rate_hz"]
        check(len(ramped) <= 40.0 / per_record + 1,
              f"{direction} steps end at the slew limit after missed deadlines: "
              f"{len(ramped)} records above 0 V")

# Three steps backwards: whole periods, the rotor's measured angle goes down.
stepped = call("step", count=3, direction="reverse", V0=60.0, f=10.0, lease_s=1.0)
check(stepped["ok"] and stepped["result"]["count"] == 3, "step: " + str(stepped))
check(stepped["result"]["duration_s"] == 0.3, "three periods at 10 Hz")
final, steps_received, last_drive, displacement = follow_run()
check(final["summary"]["cause"] == "completed", "step cause " + final["summary"]["cause"])
check(last_drive[1] == 0.0, "the steps end at 0 V")
check(len(displacement) > 100 and displacement[-1] < displacement[0] - 5e-6,
      f"reverse steps move the rotor back: {displacement[0]} -> {displacement[-1]} m")

# A closed-loop move to 2 mrad beyond where the rotor is (angles are from
# the board's zero), waited for until the board says it is on target.
def position_now():
    """The board's one axis's position (status.axes)."""
    axes = call("status")["result"]["axes"]
    check(len(axes) == 1 and "position" not in call("status")["result"],
          "status gives its one axis in axes: " + str(axes))
    return axes[0]["position"]


before = position_now()["position_rad"]
check(before is not None, "the board knows its position after a run")
target = before + 2e-3
zero_before = position_now()["zero_displacement_m"]
# The protection's arguments, as documented: a bool and 1..16 steps.
bad_protect = call("move_to", target_rad=target, protect="yes")
check(not bad_protect["ok"] and bad_protect["error"]["code"] == "bad_argument",
      "protect must be true or false: " + str(bad_protect))
bad_steps = call("move_to", target_rad=target, stall_steps=0)
check(not bad_steps["ok"] and bad_steps["error"]["code"] == "out_of_limits",
      "stall_steps 0 is refused: " + str(bad_steps))
moved = call("move_to", target_rad=target, tolerance_rad=25e-6, settle_s=0.1, timeout_s=20.0,
             lease_s=1.0, stall_steps=3)
check(moved["ok"] and len(moved["result"]["moves"]) == 1 and "move" not in moved["result"],
      "move_to of one axis: its `moves` has one: " + str(moved))
taken = moved["result"]["moves"][0]
check(taken["target_rad"] == target and taken["axis"] == hello["axes"][0]["name"],
      "move_to: " + str(moved))
check(taken["protect"] is True and taken["stall_steps"] == 3,
      "the protection as used: " + str(moved))
check(all(k in taken for k in ("V0", "f", "C_dr", "e_dr")),
      "move_to's result carries the arguments: " + str(moved))
# During the move: zero and step are the controller's, and zero waits for the end.
theirs = call("zero", socket=other)
check(theirs["error"]["code"] == "not_controller", "another client's zero: " + str(theirs))
mine = call("zero")
check(mine["error"]["code"] == "bad_state", "a zero during a run: " + str(mine))
their_step = call("step", socket=other, count=1, V0=40.0, f=100.0)
check(their_step["error"]["code"] == "not_controller" and
      their_step["error"]["message"].startswith("step"),
      "a refused step names step: " + str(their_step))
final, _, last_drive, _ = follow_run()
check("move" not in final["summary"], "a summary keeps each axis's move in axes")
move = final["summary"]["axes"][0]["move"]
check(move["on_target"] and move["stop_cause"] == "on_target", "on target: " + str(move))
check(abs(move["error_rad"]) <= 25e-6, "within the tolerance: " + str(move))
check(last_drive[1] == 0.0, "the move ends at 0 V")
check(any(u["target_rad"] == target for u in move_updates), "the stream shows the move")
position = position_now()
after = position["position_rad"]
check(abs(after - target) < 30e-6, f"status reports the position: {after} for {target}")
check(position["zero_displacement_m"] == zero_before, "the move kept the zero it started from")
zeroed = call("zero", socket=other)  # no run: any client's
check(zeroed["ok"] and abs(zeroed["result"]["position"]["position_rad"]) < 1e-12,
      "zero: " + str(zeroed))
print("ok", received[1], received[2], steps_received[1], displacement[-1] - displacement[0],
      move["steps"], move["on_target_at_s"])
