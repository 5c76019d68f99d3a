"""Sample frames (docs/protocol.md, "Sample frames") as numpy structured
arrays: little-endian, field by field."""

from __future__ import annotations

from typing import Any

import struct

import numpy as np

MAGIC = b"PZSB"
HEADER = struct.Struct("<4sHHQII")
DRIVE, SENSOR = 1, 2

DRIVE_RECORD = np.dtype([("t_ns", "<i8"), ("V", "<f8"), ("phase", "u1"), ("status", "u1"),
                         ("move_state", "u1"), ("_pad", "V5")])
SENSOR_RECORD = np.dtype([("t_request_ns", "<i8"), ("t_response_ns", "<i8"),
                          ("displacement_m", "<f8"), ("status", "u1"), ("_pad", "V7")])
RECORDS = {DRIVE: DRIVE_RECORD, SENSOR: SENSOR_RECORD}
STREAM_NAMES = {DRIVE: "drive", SENSOR: "sensor"}


class FrameError(ValueError):
    """A frame whose magic, version, stream, record size or length is wrong."""


def decode(body: bytes) -> tuple[int, int, np.ndarray[Any, Any]]:
    """(stream, first sequence number, records) of one frame; refuses any
    frame that does not match the documented layout."""
    if len(body) < HEADER.size:
        raise FrameError(f"frame of {len(body)} bytes, shorter than its header")
    magic, version, stream, first, count, size = HEADER.unpack_from(body)
    if magic != MAGIC or version != 1:
        raise FrameError(f"frame magic {magic!r} version {version}")
    dtype = RECORDS.get(stream)
    if dtype is None or size != dtype.itemsize:
        raise FrameError(f"stream {stream} with {size}-byte records")
    if len(body) != HEADER.size + count * size:
        raise FrameError(f"frame of {len(body)} bytes for {count} records")
    return stream, first, np.frombuffer(body, dtype, count, HEADER.size).copy()
