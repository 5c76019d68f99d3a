"""Sample frames (docs/protocol.md, "Sample frames") as numpy structured
arrays, decoded by the layout the board describes (``describe``'s
``frames``): the header's and each stream's record fields with their types
and offsets, so no copy of the layout lives here."""

from __future__ import annotations

from ._wire import Key
from typing import Any

import numpy as np


class FrameError(ValueError):
    """A frame whose magic, version, stream, record size or length is wrong."""


def _dtype(fields: list[dict[str, Any]], itemsize: int) -> np.dtype[Any]:
    """A structured type with each described field at its offset."""
    return np.dtype({"names": [f[Key.name] for f in fields],  # numpy's spec, not the wire's
                     "formats": [f[Key.type] for f in fields],
                     "offsets": [int(f[Key.offset]) for f in fields],
                     "itemsize": itemsize})


class Layout:
    """A board's frame layout, from its dictionary's ``frames``.

    >>> layout = Layout({"magic": "PZSB", "version": 1, "header_bytes": 8,
    ...                  "header": [{"name": "count", "type": "<u4", "offset": 0}],
    ...                  "streams": {"drive": {"id": 1, "record_bytes": 8, "fields": [
    ...                      {"name": "V", "type": "<f8", "offset": 0}]}}})
    >>> layout.record("drive").names
    ('V',)
    """

    def __init__(self, described: dict[str, Any]) -> None:
        self.magic = str(described[Key.magic]).encode()
        self.version = int(described[Key.version])
        self.header = _dtype(described[Key.header], int(described[Key.header_bytes]))
        streams = described[Key.streams]
        self.names = {int(s[Key.id]): name for name, s in streams.items()}
        self.ids = {name: stream_id for stream_id, name in self.names.items()}
        self.records = {int(s[Key.id]): _dtype(s[Key.fields], int(s[Key.record_bytes]))
                        for s in streams.values()}

    def record(self, stream: str) -> np.dtype[Any]:
        """The record type of the stream named ``stream`` ("drive", "sensor")."""
        return self.records[self.ids[stream]]

    def decode(self, body: bytes) -> tuple[int, int, np.ndarray[Any, Any]]:
        """(stream id, first sequence number, records) of one frame; refuses
        any frame that does not match the described layout."""
        if len(body) < self.header.itemsize:
            raise FrameError(f"frame of {len(body)} bytes, shorter than its header")
        header = np.frombuffer(body, self.header, 1)[0]
        if bytes(header[Key.magic]) != self.magic or int(header[Key.version]) != self.version:
            raise FrameError(f"frame magic {bytes(header['magic'])!r} version "
                             f"{int(header['version'])}")
        stream, count, size = int(header[Key.stream]), int(header[Key.count]), int(header[Key.record_bytes])
        dtype = self.records.get(stream)
        if dtype is None or size != dtype.itemsize:
            raise FrameError(f"stream {stream} with {size}-byte records")
        if len(body) != self.header.itemsize + count * size:
            raise FrameError(f"frame of {len(body)} bytes for {count} records")
        records = np.frombuffer(body, dtype, count, self.header.itemsize).copy()
        return stream, int(header[Key.first]), records
