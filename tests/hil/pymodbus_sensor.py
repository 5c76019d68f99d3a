#!/usr/bin/python3
"""An independent Modbus peer posing as a Baumer OM30 sensor (pymodbus, from
Debian): input registers 202-203 hold 0x7C37, 0x428B, i.e. 69.7426 mm as an
f32 in CDAB order. Usage: pymodbus_sensor.py tcp PORT | rtu DEVICE PARITY"""
import sys

from pymodbus.datastore import (ModbusSequentialDataBlock, ModbusServerContext,
                                ModbusSlaveContext)
from pymodbus.server import StartSerialServer, StartTcpServer
from pymodbus.transaction import ModbusRtuFramer

inputs = ModbusSequentialDataBlock(0, [0] * 300)
inputs.setValues(202, [0x7C37, 0x428B])
store = ModbusSlaveContext(ir=inputs, hr=ModbusSequentialDataBlock(0, [0] * 10), zero_mode=True)
context = ModbusServerContext(slaves=store, single=True)
if sys.argv[1] == "tcp":
    StartTcpServer(context=context, address=("127.0.0.1", int(sys.argv[2])))
else:
    # pyserial cannot reconfigure a pseudo-terminal that has parity set
    # (tcsetattr gives EINVAL), so over a pty pair the test uses 8N1.
    StartSerialServer(context=context, framer=ModbusRtuFramer, port=sys.argv[2], baudrate=57600,
                      parity=sys.argv[3], bytesize=8, stopbits=1, timeout=0.01)
