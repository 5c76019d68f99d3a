#!/usr/bin/python3
"""A Modbus peer posing as a Baumer OM30 sensor (pymodbus, from Debian) that
misbehaves the way real ones do: input registers 202-203 hold an f32 in CDAB
order, in millimetres, changed on every read by the mode:

  steady   69.7426 mm (a rotor that stays)
  spike    69.7426 mm, +5 mm on every 200th read
  nan      69.7426 mm, NaN on every 100th read
  garbage  random words on every read
  huge     69.7426 mm, and on every 100th read in turn 3.4e35 m, -1000 m
           and a 1e6 mm spike (a laser spot off the rotor, a lost lock)

Usage: wild_sensor.py MODE PORT"""
import random
import struct
import sys

from pymodbus.datastore import (ModbusSequentialDataBlock, ModbusServerContext,
                                ModbusSlaveContext)
from pymodbus.server import StartTcpServer

mode, port = sys.argv[1], int(sys.argv[2])
BASE_MM = 69.7426
rng = random.Random(7)


def cdab(mm):
    hi, lo = struct.unpack(">HH", struct.pack(">f", mm))
    return [lo, hi]


class WildBlock(ModbusSequentialDataBlock):
    reads = 0

    def getValues(self, address, count=1):  # noqa: N802 - pymodbus's name
        if address == 202 and count == 2:
            WildBlock.reads += 1
            n = WildBlock.reads
            if mode == "garbage":
                return [rng.randrange(65536), rng.randrange(65536)]
            if mode == "spike" and n % 200 == 0:
                return cdab(BASE_MM + 5.0)
            if mode == "nan" and n % 100 == 0:
                return cdab(float("nan"))
            if mode == "huge" and n % 100 == 0:
                return cdab((3.4e38, -1.0e6, 1.0e6)[(n // 100) % 3])
            return cdab(BASE_MM)
        return super().getValues(address, count)


store = ModbusSlaveContext(ir=WildBlock(0, [0] * 300), hr=ModbusSequentialDataBlock(0, [0] * 10),
                           zero_mode=True)
StartTcpServer(context=ModbusServerContext(slaves=store, single=True),
               address=("127.0.0.1", port))
