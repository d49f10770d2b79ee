"""Scalar arithmetic with numpy's semantics, for the per-tick code that runs on Python floats.

The firmware's tick works on vectors of 3 to 9 elements, where a numpy call costs more than the
arithmetic it does, so its estimator, controller, feed-forward, mixer and preview compute per axis in
Python floats. IEEE scalar arithmetic gives the same bits as numpy's elementwise operations; where the
two differ is at the edges: Python raises where numpy returns inf or NaN (a division by zero, a root of
a negative number, an overflowing power), and ``min``/``max`` treat NaN and signed zeros otherwise than
``np.minimum``/``np.maximum``. The functions here return what numpy would, so a tick gives the same
results, bit for bit, whichever form it is written in.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["clip_float", "ratio", "sqrt", "square_over"]


def clip_float(x: float, lo: float, hi: float) -> float:
    """``np.clip(x, lo, hi)`` (array bounds) and ``np.minimum(np.maximum(x, lo), hi)`` for one float, to the bit.

    numpy's comparisons spelt out: NaN passes through, and a tie (±0 against ∓0) takes the bound.
    """
    m = x if (x > lo or x != x) else lo
    return m if (m < hi or m != m) else hi


def ratio(a: float, b: float) -> float:
    """a / b in IEEE arithmetic, as numpy divides: ±inf or NaN (and numpy's warning) for b = 0 where Python
    would raise."""
    try:
        return a / b
    except ZeroDivisionError:
        with np.errstate(invalid="ignore"):
            return float(np.float64(a) / np.float64(b))


def sqrt(v: float) -> float:
    """√v as numpy computes it: NaN (not Python's ValueError) below zero."""
    return math.sqrt(v) if v >= 0.0 else math.nan


def square_over(a: float, b: float) -> float:
    """a ** 2 / b as numpy's float64 scalars compute it (pow, then division; pow(a, 2) is not always a·a),
    inf or NaN where Python would raise."""
    try:
        return a ** 2 / b
    except (OverflowError, ZeroDivisionError):
        return float(np.float64(a) ** 2 / np.float64(b))
