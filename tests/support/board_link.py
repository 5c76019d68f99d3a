"""A board's link passed through the test's process, to be cut, mended and
spoken into: what a client of the board hears when the network fails or
carries what the board never sent."""

import socket
import select
import threading

import zmq

import peers


class Link:
    """The board's two ports passed through this process (a link that can be
    cut and mended): its commands byte for byte, its stream through an
    XPUB/XSUB pair with a publisher of this test's beside the board's, so a
    client hears the board's messages and whatever is put in."""

    def __init__(self, board_address):
        host, port = board_address.rsplit(":", 1)
        self.board_port = int(port)
        self.port = peers.free_port(2)
        self.address = f"tcp://127.0.0.1:{self.port}"
        self.context = zmq.Context()
        self.inject = self.context.socket(zmq.PUB)
        self.inject.bind("inproc://injected")
        self.up()

    def up(self):
        self._stop = threading.Event()
        self._threads = [threading.Thread(target=self._commands, daemon=True),
                         threading.Thread(target=self._stream, daemon=True)]
        self._ready = threading.Barrier(3)
        for t in self._threads:
            t.start()
        self._ready.wait(5)

    def down(self):
        self._stop.set()
        for t in self._threads:
            t.join(5)

    def _commands(self):
        listener = socket.create_server(("127.0.0.1", self.port), reuse_port=False)
        listener.settimeout(0.05)
        self._ready.wait(5)
        pairs = []
        while not self._stop.is_set():
            try:
                client, _ = listener.accept()
            except socket.timeout:
                pass
            else:
                board = socket.create_connection(("127.0.0.1", self.board_port))
                pairs.append((client, board))
            ready, _, _ = select.select([s for p in pairs for s in p], [], [], 0.02)
            for s in ready:
                pair = next(p for p in pairs if s in p)
                other = pair[1] if s is pair[0] else pair[0]
                data = s.recv(65536)
                if data:
                    other.sendall(data)
                else:
                    pairs.remove(pair)
                    pair[0].close()
                    pair[1].close()
        for a, b in pairs:
            a.close()
            b.close()
        listener.close()

    def _stream(self):
        c = self.context
        xpub, xsub = c.socket(zmq.XPUB), c.socket(zmq.XSUB)
        for s in (xpub, xsub):
            s.setsockopt(zmq.LINGER, 0)
        xpub.bind(f"tcp://127.0.0.1:{self.port + 1}")
        xsub.connect(f"tcp://127.0.0.1:{self.board_port + 1}")
        xsub.connect("inproc://injected")
        poller = zmq.Poller()
        poller.register(xpub, zmq.POLLIN)
        poller.register(xsub, zmq.POLLIN)
        pairs = {xpub: xsub, xsub: xpub}
        self._ready.wait(5)
        while not self._stop.is_set():
            for s, _ in poller.poll(50):
                pairs[s].send_multipart(s.recv_multipart())
        xpub.close()
        xsub.close()

    def put(self, *parts):
        self.inject.send_multipart(list(parts))

    def close(self):
        self.down()
        self.inject.close()
        self.context.term()
