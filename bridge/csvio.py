"""Reading the small numeric CSV files users hand Wavekeep (buoy spectra, thrust demand profiles)."""
from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

__all__ = ["read_numeric_csv"]


def read_numeric_csv(path: str | Path, columns: tuple[str, ...]) -> np.ndarray:
    """Rows of ``len(columns)`` finite numbers (the first that many fields of each line), as (K, n).

    Blank lines and lines starting with ``#`` are skipped, and the first line may
    be a header. Anything else that is not numbers raises ValueError naming the
    file, the line and the columns expected.
    """
    n = len(columns)
    rows = []
    with open(path, newline="", encoding="utf-8") as fh:
        for i, row in enumerate(csv.reader(fh)):
            if not row or row[0].lstrip().startswith("#"):
                continue
            try:
                values = [float(v) for v in row[:n]]
            except ValueError:
                if i == 0:
                    continue    # header
                values = []
            if len(values) != n or not all(math.isfinite(v) for v in values):
                raise ValueError(f"{path}: line {i + 1}: expected {n} finite numbers {', '.join(columns)}")
            rows.append(values)
    if not rows:
        raise ValueError(f"{path}: no rows of {', '.join(columns)}")
    return np.array(rows, dtype=float)
