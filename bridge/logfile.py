"""A process's log written whole or not at all: a CSV of rows saved to a temporary name, then renamed.

The plant and the firmware write their per-step logs when they stop. A reader (the launcher)
must never find half a file: one killed while writing leaves no log at all, so a short log
can only mean the process logged fewer rows, never that its writing was cut off.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

__all__ = ["save_csv_whole"]


def save_csv_whole(path: str | os.PathLike, rows, header: str, fmt: str = "%.17g") -> None:
    """``np.savetxt(path, rows)`` with ``header``, appearing at ``path`` only once complete (same folder,
    ``os.replace``); ``%.17g`` by default, so floats read back bit for bit."""
    target = Path(path)
    tmp = target.with_name(f".{target.name}.part")
    try:
        np.savetxt(tmp, rows, delimiter=",", header=header, comments="", fmt=fmt)
        os.replace(tmp, target)
    finally:
        tmp.unlink(missing_ok=True)
