#!/usr/bin/python3
"""Control never waits behind viewers: `piezo view --rig ... --control`
against the simulated board, with 50 live pages reading, 50 slow senders
trickling a byte a second and unauthenticated requests flooding, all at
once. Twenty E-stops and Stops from the view (alternately) must each be
answered, and the board must hold the E-stop. Prints the answers' latency
(docs/live-view.md quotes it; a figure, not an assertion: machines are noisy) and
what the viewers and the flood got meanwhile.

Usage: view_load_check.py PIEZO PIEZOD
"""
import asyncio
import http.client
import json
import os
import re
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time

SOURCE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(SOURCE, "tests", "support"))
import peers  # noqa: E402
from peers import free_port, start_piezod  # noqa: E402
LIVE_PAGES, SLOW_SENDERS, FLOODERS, TRIES = 50, 50, 8, 20


def check(condition, what):
    if not condition:
        print("FAILED:", what)
        sys.exit(1)


class Load:
    """The viewers, slow senders and flood, on an event loop of their own."""

    def __init__(self, port):
        self.port = port
        self.stop = False
        self.live_bytes = 0
        self.live_open = 0
        self.flood_answers = {}
        self.slow_connections = 0

    async def live_page(self):
        reader, writer = await asyncio.open_connection("127.0.0.1", self.port)
        writer.write(b"GET /api/live HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
        await writer.drain()
        self.live_open += 1
        while not self.stop:
            chunk = await reader.read(65536)
            if not chunk:
                break
            self.live_bytes += len(chunk)
        writer.close()

    async def slow_sender(self):
        while not self.stop:
            try:
                reader, writer = await asyncio.open_connection("127.0.0.1", self.port)
                self.slow_connections += 1
                writer.write(b"GET /api/live.json HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: ")
                while not self.stop and not reader.at_eof():
                    writer.write(b"a")
                    await writer.drain()
                    await asyncio.sleep(1.0)
                writer.close()
            except OSError:
                await asyncio.sleep(0.1)

    async def flooder(self, i):
        requests = [
            b"POST /api/estop HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 2\r\n\r\n{}",
            b"POST /api/stop HTTP/1.1\r\nHost: evil.example\r\nContent-Length: 2\r\n\r\n{}",
            b"GET /api/live.json HTTP/1.1\r\nHost: evil.example\r\n\r\n",
            b"POST /api/stop HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 805306368\r\n\r\n",
        ]
        n = i
        while not self.stop:
            n += 1
            try:
                reader, writer = await asyncio.open_connection("127.0.0.1", self.port)
                writer.write(requests[n % len(requests)])
                await writer.drain()
                status = (await reader.readline()).split(b" ")[1:2]
                key = status[0].decode() if status else "none"
                self.flood_answers[key] = self.flood_answers.get(key, 0) + 1
                writer.close()
            except (OSError, IndexError):
                self.flood_answers["error"] = self.flood_answers.get("error", 0) + 1
                await asyncio.sleep(0.01)

    async def run(self):
        tasks = [asyncio.create_task(self.live_page()) for _ in range(LIVE_PAGES)]
        tasks += [asyncio.create_task(self.slow_sender()) for _ in range(SLOW_SENDERS)]
        tasks += [asyncio.create_task(self.flooder(i)) for i in range(FLOODERS)]
        while not self.stop:
            await asyncio.sleep(0.1)
        for t in tasks:
            t.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)


def rss_kib(pid):
    with open(f"/proc/{pid}/status") as f:
        return int(re.search(r"VmRSS:\s+(\d+)", f.read()).group(1))


def huge_body(port, head):
    """Sends a head and up to 768 MiB of body, as fast as the view takes it;
    returns the status line it answered and how much it took."""
    sent = 0
    with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
        s.sendall(head)
        block = b"x" * (1 << 20)
        try:
            while sent < 768 << 20:
                s.sendall(b"%x\r\n" % len(block) + block + b"\r\n" if b"chunked" in head else block)
                sent += len(block)
        except OSError:
            pass
        try:
            answer = s.recv(64).split(b"\r\n")[0].decode()
        except OSError as e:
            answer = f"no answer ({e})"
    return answer, sent


def control(port, token, what):
    """One POST from the page's own origin; its status and latency [ms]."""
    start = time.perf_counter()
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    try:
        c.request("POST", "/api/" + what, body=b"{}",
                  headers={"X-Piezo-Token": token, "Content-Type": "application/json"})
        status = c.getresponse().status
    except OSError as e:
        status = f"no answer ({e})"
    finally:
        c.close()
    return status, (time.perf_counter() - start) * 1e3


def main():
    piezo, piezod = sys.argv[1], sys.argv[2]
    work = tempfile.mkdtemp(prefix="piezo-view-load-")
    board, address = start_piezod(piezod, os.path.join(SOURCE, "configs", "piezod-sim.toml"),
                                  os.path.join(work, "piezod.err"))
    view = None
    try:
        err = os.path.join(work, "view.err")
        url = token = None
        for _ in range(5):  # a board still starting may leave the view's hello unanswered
            port = free_port()
            view = peers.spawn([piezo, "view", "--rig", address, "--control", "--listen",
                                     f"127.0.0.1:{port}"], stderr=open(err, "w"))
            deadline = time.time() + 60
            while time.time() < deadline and view.poll() is None and not url:
                m = re.search(r"live view: (http://\S+?)\?token=([0-9a-f]+) ", open(err).read())
                url, token = (m.group(1), m.group(2)) if m else (None, None)
                time.sleep(0.05)
            if url:
                break
            view.kill()
            view.wait()
        check(url, "the view's banner: " + open(err).read())

        # A stranger's 768 MiB body, announced and chunked: refused, unread.
        rss_before = rss_kib(view.pid)
        for head in (b"POST /api/stop HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: text/plain\r\n"
                     b"Content-Length: 805306368\r\n\r\n",
                     b"POST /api/stop HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Piezo-Token: " +
                     token.encode() + b"\r\nTransfer-Encoding: chunked\r\n\r\n"):
            answer, sent = huge_body(port, head)
            grew = rss_kib(view.pid) - rss_before
            print(f"768 MiB body ({'chunked' if b'chunked' in head else 'announced'}): "
                  f"{answer!r} after {sent >> 20} MiB sent; the view's RSS grew {grew} KiB")
            check(answer.split(" ")[1:2] == ["413"], f"refused 413: {answer}")
            check(grew < 16 * 1024, f"RSS grew {grew} KiB")

        load = Load(port)
        loop = asyncio.new_event_loop()
        thread = threading.Thread(target=lambda: loop.run_until_complete(load.run()))
        thread.start()
        deadline = time.time() + 30
        while time.time() < deadline and load.live_open < LIVE_PAGES:
            time.sleep(0.05)
        time.sleep(2.0)  # the slow senders hold their connections, the flood runs
        answers = []
        for i in range(TRIES):
            answers.append((("estop", "stop")[i % 2],) + control(port, token, ("estop", "stop")[i % 2]))
            time.sleep(0.1)
        flood, live_bytes, slow = dict(load.flood_answers), load.live_bytes, load.slow_connections
        load.stop = True
        thread.join(timeout=30)

        latencies = sorted(ms for _, _, ms in answers)
        p99 = latencies[min(len(latencies) - 1, int(0.99 * len(latencies)))]
        print(f"{TRIES} control requests under {LIVE_PAGES} live pages, {SLOW_SENDERS} slow senders "
              f"and {FLOODERS} flooders: p50 {statistics.median(latencies):.1f} ms, "
              f"p99 {p99:.1f} ms, max {latencies[-1]:.1f} ms")
        print(f"meanwhile: {live_bytes / 1024:.0f} KiB to the live pages, {slow} slow connections, "
              f"flood answers by status {flood}")
        for what, status, ms in answers:
            check(status in (200, 409), f"{what} answered: {status} after {ms:.0f} ms")
        check(all(s == 200 for w, s, _ in answers if w == "estop"), f"every e-stop taken: {answers}")
        check(live_bytes > 0, "the live pages were served")
        check(flood.get("403", 0) > 0 and flood.get("413", 0) > 0, f"the flood refused: {flood}")
        state = json.loads(subprocess.run([piezo, "status", "--rig", address, "--json"],
                                          capture_output=True, text=True).stdout)
        check(state["fault"] == "estop", f"the board latched the e-stop: {state['fault']}")
        print("ok")
    finally:
        if view and view.poll() is None:
            view.terminate()
            view.wait(timeout=10)
        board.terminate()
        board.wait(timeout=10)
        subprocess.run(["rm", "-rf", work])


if __name__ == "__main__":
    main()
