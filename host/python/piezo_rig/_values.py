"""Equality by value for the package's result types, whose fields hold
numpy arrays and DataFrames: the dataclasses' own ``==`` compares them as
tuples and raises "the truth value of an array ... is ambiguous"."""

from __future__ import annotations

from dataclasses import fields
from typing import Any, TypeVar

import numpy as np
import pandas as pd


def same(a: Any, b: Any) -> bool:
    """a and b equal by value: arrays element by element (NaN where both
    have it is equal: a failed reading in both), frames cell by cell."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        try:
            return bool(np.array_equal(a, b, equal_nan=True))
        except TypeError:  # not numbers: no NaN to match
            return bool(np.array_equal(a, b))
    if isinstance(a, pd.DataFrame) or isinstance(b, pd.DataFrame):
        return isinstance(a, pd.DataFrame) and isinstance(b, pd.DataFrame) and a.equals(b)
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    return bool(a == b)


def dataclass_eq(self: Any, other: Any) -> Any:
    """``__eq__`` for a dataclass declared with ``eq=False``: the same type
    and every compared field ``same``."""
    if other.__class__ is not self.__class__:
        return NotImplemented
    return all(same(getattr(self, f.name), getattr(other, f.name)) for f in fields(self)
               if f.compare)


Result = TypeVar("Result")


def by_value(cls: type[Result]) -> type[Result]:
    """Class decorator for a dataclass declared ``eq=False``: ``==``
    compares by value (``dataclass_eq``), and the class is unhashable, as
    a mutable value should be."""
    setattr(cls, "__eq__", dataclass_eq)
    setattr(cls, "__hash__", None)
    return cls
