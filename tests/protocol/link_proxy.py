#!/usr/bin/python3
"""A TCP proxy between piezo and piezod that can cut the link: forwards
LISTEN_PORT -> TARGET_PORT and LISTEN_PORT+1 -> TARGET_PORT+1 (commands and
stream). On SIGUSR1 it closes every connection and refuses new ones for
OUTAGE_S seconds, as a cable pulled and plugged back in.
usage: link_proxy.py LISTEN_PORT TARGET_PORT OUTAGE_S"""
import asyncio
import signal
import sys

listen_port, target_port, outage_s = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])
connections = set()
link_down = False


async def pipe(reader, writer):
    try:
        while True:
            data = await reader.read(65536)
            if not data or link_down:
                break
            writer.write(data)
            await writer.drain()
    except (ConnectionError, asyncio.CancelledError):
        pass
    finally:
        writer.close()


def handler(target):
    async def handle(reader, writer):
        if link_down:
            writer.close()
            return
        try:
            up_reader, up_writer = await asyncio.open_connection("127.0.0.1", target)
        except OSError:
            writer.close()
            return
        pair = (writer, up_writer)
        connections.add(pair)
        await asyncio.gather(pipe(reader, up_writer), pipe(up_reader, writer))
        connections.discard(pair)
    return handle


async def outage():
    global link_down
    link_down = True
    for a, b in list(connections):
        a.transport.abort()
        b.transport.abort()
    print("link down", flush=True)
    await asyncio.sleep(outage_s)
    link_down = False
    print("link up", flush=True)


async def main():
    loop = asyncio.get_running_loop()
    loop.add_signal_handler(signal.SIGUSR1, lambda: asyncio.ensure_future(outage()))
    servers = [await asyncio.start_server(handler(target_port + i), "127.0.0.1", listen_port + i)
               for i in (0, 1)]
    print("ready", flush=True)
    await asyncio.gather(*(s.serve_forever() for s in servers))


asyncio.run(main())
