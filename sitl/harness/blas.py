"""One BLAS thread per process.

A mission's matrices are small (6×6 to about 1200×100): a second BLAS thread
cannot speed them up, and on a busy machine its spin-waiting costs far more
than it saves — an in-process DSWP mission measured 20–100× the CPU time of a
single-threaded one on the shared 2-core machine (docs/benchmarks.md). The
processes of ``wavekeep sim``, the campaign's workers and ``wavekeep`` itself
therefore run with one thread, unless the user's environment says otherwise.
Results do not depend on it: ``sim``'s single-threaded processes give the
in-process run's results bit for bit (tests/test_launcher.py).
"""
from __future__ import annotations

import os
from collections.abc import MutableMapping

__all__ = ["ONE_BLAS_THREAD", "use_one_blas_thread"]

ONE_BLAS_THREAD = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
"""The environment that gives numpy's BLAS one thread (OpenBLAS, MKL or an OpenMP build)."""


def use_one_blas_thread(environ: MutableMapping[str, str] = os.environ) -> None:
    """Set :data:`ONE_BLAS_THREAD` where ``environ`` does not already choose. Takes effect only before
    numpy is first imported in this process (the CLI imports it lazily, after this)."""
    for key, value in ONE_BLAS_THREAD.items():
        environ.setdefault(key, value)
