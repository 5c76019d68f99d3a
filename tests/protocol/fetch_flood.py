#!/usr/bin/python3
"""A watcher flooding piezod with fetch (from docs/protocol.md): N requests
of COUNT drive samples each, sent without waiting, then whatever replies
come within 3 s. Prints: ok rate_limited other seconds (from the first send
to the last reply).
usage: fetch_flood.py tcp://127.0.0.1:PORT N COUNT"""
import sys
import time

import msgpack
import zmq

address, n, count = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
sock = zmq.Context().socket(zmq.DEALER)
sock.connect(address)
start = time.monotonic()
for i in range(n):
    sock.send(msgpack.packb({"id": i + 1, "cmd": "fetch",
                             "args": {"stream": "drive", "first": 0, "count": count}}))
ok = limited = other = 0
last = start
while sock.poll(3000):
    reply = msgpack.unpackb(sock.recv(), raw=False)
    last = time.monotonic()
    if reply["ok"]:
        ok += 1
    elif reply["error"]["code"] == "rate_limited":
        limited += 1
    else:
        other += 1
print(ok, limited, other, f"{last - start:.3f}")
