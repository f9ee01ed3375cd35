"""Checks of user input, shared by every constructor and setter.

Each check returns the value in the type the engine stores, or raises a
ValueError/TypeError whose message names the argument. There is one message per
kind of check, so a constructor and the setter of the same parameter say the
same thing.
"""

from __future__ import annotations

import math

import numpy as np

MAX_COUNT = 100_000  # sweeps, passes, sub-steps per step: far past convergence, and buffers stay small


def finite_float(value, name: str) -> float:
    """``value`` as a finite float."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__}")
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {v}")
    return v


def positive_float(value, name: str) -> float:
    """``value`` as a finite float > 0."""
    v = finite_float(value, name)
    if v <= 0.0:
        raise ValueError(f"{name} must be > 0, got {v}")
    return v


def non_negative_float(value, name: str) -> float:
    """``value`` as a finite float >= 0."""
    v = finite_float(value, name)
    if v < 0.0:
        raise ValueError(f"{name} must be >= 0, got {v}")
    return v


def float_in(value, name: str, low: float, high: float) -> float:
    """``value`` as a finite float in [low, high]."""
    v = finite_float(value, name)
    if not low <= v <= high:
        raise ValueError(f"{name} must be in [{low:g}, {high:g}], got {v}")
    return v


def optional_non_negative_float(value, name: str) -> float | None:
    """None, or ``value`` as a finite float >= 0."""
    return None if value is None else non_negative_float(value, name)


def vec2(value, name: str) -> np.ndarray:
    """``value`` as a finite float64 (2,) array."""
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{name} must be a pair of numbers (x, y), got {type(value).__name__}")
    try:
        a = np.asarray(value)
    except Exception as exc:  # ragged input and the like
        raise TypeError(f"{name} must be a pair of numbers (x, y): {exc}") from None
    if a.dtype == object or a.dtype.kind not in "iuf":
        raise TypeError(f"{name} must be a pair of numbers (x, y), got {value!r}")
    if a.shape != (2,):
        raise ValueError(f"{name} must have shape (2,), got shape {a.shape}")
    a = a.astype(np.float64)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite, got {a.tolist()}")
    return a


def check_int(value, name: str, low: int, high: int = MAX_COUNT) -> int:
    """``value`` as an int in [low, high] (bools are refused)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")
    if not low <= value <= high:
        raise ValueError(f"{name} must be between {low} and {high}, got {value}")
    return int(value)


MAX_BITS = (1 << 64) - 1  # category and mask are 64-bit masks, as Box2D's
GROUP_RANGE = (-(1 << 31), (1 << 31) - 1)  # group is a 32-bit signed int


def filter_bits(value, name: str) -> int:
    """``value`` as a 64-bit mask of collision categories (``category``, ``mask``): an int in
    [0, 2^64 - 1] (bools are refused)."""
    return check_int(value, name, 0, MAX_BITS)


def filter_group(value, name: str = "group") -> int:
    """``value`` as a collision group: a 32-bit signed int (0: no group)."""
    return check_int(value, name, *GROUP_RANGE)


def check_bool(value, name: str) -> bool:
    """``value`` as a bool (numpy bools too; 0 and 1 are refused)."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def one_of(value, name: str, choices: tuple[str, ...]) -> str:
    """``value`` if it is one of the strings in ``choices``."""
    if not isinstance(value, str) or value not in choices:
        listed = ", ".join(repr(c) for c in choices[:-1]) + f" or {choices[-1]!r}"
        raise ValueError(f"{name} must be {listed}, got {value!r}")
    return value


class Setting:
    """A parameter checked by ``check(value, name)`` on every assignment: in the
    constructor and afterwards alike, so both give the same message."""

    def __init__(self, check, doc: str = "") -> None:
        self.check = check
        self.__doc__ = doc

    def __set_name__(self, owner, name: str) -> None:
        self.name = name

    def __get__(self, obj, objtype=None):
        if obj is None:
            return self
        return obj.__dict__[self.name]

    def __set__(self, obj, value) -> None:
        obj.__dict__[self.name] = self.check(value, self.name)
