#!/usr/bin/python3
"""An independent piezod client, written from docs/protocol.md alone
(python3-zmq, python3-msgpack): hello and status, a malformed message and a
request beyond the board's limits (error replies, the daemon goes on), then
a short run whose samples arrive on the stream, and a fetch from the
recorder. Prints "ok" and facts; exits non-zero on any mismatch.
usage: protocol_client.py tcp://127.0.0.1:PORT"""
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
for topic in (b"drive", b"sensor", b"state"):
    sub.setsockopt(zmq.SUBSCRIBE, topic)
next_id = 0


def call(name, **args):
    global next_id
    next_id += 1
    cmd.send(msgpack.packb({"id": next_id, "cmd": name, "args": args}))
    if not cmd.poll(3000):
        sys.exit(f"{name}: no reply")
    reply = msgpack.unpackb(cmd.recv(), raw=False)
    assert reply["id"] == next_id, reply
    return reply


def check(condition, what):
    if not condition:
        sys.exit("FAILED: " + what)


def frame_header(body):
    magic, version, stream, first, count, record = struct.unpack_from("<4sHHQII", body)
    check(magic == b"PZSB" and version == 1, "frame magic/version")
    check(len(body) == 24 + count * record, "frame length")
    return stream, first, count, record


hello = call("hello")["result"]
check(hello["protocol"] == 1, "protocol version")
limits = hello["limits"]
status = call("status")["result"]
check(status["state"] == "idle", "idle at start: " + status["state"])

cmd.send(b"\xc1 not msgpack")
check(cmd.poll(3000), "reply to a malformed message")
bad = msgpack.unpackb(cmd.recv(), raw=False)
check(not bad["ok"] and bad["error"]["code"] == "malformed", "malformed -> error")
unknown = call("fly")
check(unknown["error"]["code"] == "unknown_command", "unknown command")
beyond = call("configure", V0=limits["V_max"] + 10, f=10.0, duration_s=0.5)
check(beyond["error"]["code"] == "out_of_limits" and beyond["error"]["key"] == "V0",
      "beyond the limits: " + str(beyond))
wrong_type = call("configure", V0="high", f=10.0, duration_s=0.5)
check(wrong_type["error"]["key"] == "V0", "wrong type named")

check(call("configure", V0=60.0, f=10.0, duration_s=0.5)["ok"], "configure")
time.sleep(0.2)
started = call("start", lease_s=1.0)
check(started["ok"], "start: " + str(started))
received = {1: 0, 2: 0}
last_drive = None
deadline = time.time() + 30
final = None
while time.time() < deadline and final is None:
    if sub.poll(100):
        topic, body = sub.recv_multipart()
        if topic == b"state":
            event = msgpack.unpackb(body, raw=False)
            if event["state"] in ("idle", "fault") and "summary" in event:
                final = event
            continue
        stream, first, count, record = frame_header(body)
        check(first == received[stream], f"stream {stream} in sequence")
        received[stream] += count
        if stream == 1 and count:
            last_drive = struct.unpack_from("<qdBB", body, 24 + (count - 1) * record)
    call("lease", drive_received=received[1])

check(final is not None, "the run ended")
summary = final["summary"]
check(summary["cause"] == "completed", "cause " + summary["cause"])
check(received[1] == summary["samples"]["drive"], "every drive sample streamed")
check(received[2] == summary["samples"]["sensor"], "every sensor sample streamed")
check(last_drive[1] == 0.0 and last_drive[2] == 2, "the drive ends stopped at 0 V")
fetched = call("fetch", stream="sensor", first=10, count=5)["result"]["frame"]
stream, first, count, record = frame_header(fetched)
check(stream == 2 and first == 10 and count == 5, "fetch from the recorder")
print("ok", received[1], received[2])
