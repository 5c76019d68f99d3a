"""piezo_rig: the stick-slip piezo rotary motor rig from Python.

- ``piezo_rig.model``: the LuGre and Coulomb models (the project's C++,
  no subprocess): simulate, the sensitivity studies, sweeps, identification.
- ``piezo_rig.board``: a client of ``piezod`` (docs/protocol.md): runs that
  stream numpy blocks, steps, closed-loop moves, the zero, stop and e-stop.
- ``piezo_rig.log``: a run's log (``run.h5``, another tool's HDF5 or a
  MATLAB v7.3 file) as numpy arrays and pandas DataFrames.

The guide is docs/python.md (installed with the package's examples in
/usr/share/doc/python3-piezo-rig).
"""

__version__ = "0.1.0"
__all__ = ["model", "board", "log"]
