"""filterpy's ``ExtendedKalmanFilter``, imported without the rest of filterpy (and scipy.stats).

``import filterpy.kalman`` runs filterpy's package ``__init__``, which imports
every filter filterpy ships and, through ``filterpy.stats``, ``scipy.stats``:
0.6–1 s of a run's start on the 2-core machine, for one class. This module
loads filterpy's own ``filterpy/kalman/EKF.py``, unmodified, as a private
module. For its two project imports it sees ``filterpy.common.helpers`` (pure
numpy, filterpy's file) and a ``filterpy.stats`` whose ``logpdf`` imports the
real one on first call (only ``EKF.log_likelihood`` uses it, the firmware
never). The stand-ins live in ``sys.modules`` only while EKF.py executes, so a
later ``import filterpy`` is the real thing. If filterpy is already imported,
its class is used as is. EKF.py itself imports ``scipy.linalg`` (its
``update`` inverts S with it), which stays.
"""
from __future__ import annotations

import importlib
import importlib.util
import sys
import types
from pathlib import Path

__all__ = ["ExtendedKalmanFilter"]


def _exec_file(name: str, path: Path) -> types.ModuleType:
    """Execute the Python file at ``path`` as a fresh module called ``name`` (not registered)."""
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ImportError(f"cannot load {path}")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _lazy_logpdf(*args, **kwargs):
    """filterpy.stats.logpdf, imported on first use."""
    return importlib.import_module("filterpy.stats").logpdf(*args, **kwargs)


def _load() -> type:
    """The ExtendedKalmanFilter class (see the module docstring)."""
    if "filterpy.kalman" in sys.modules:
        return sys.modules["filterpy.kalman"].ExtendedKalmanFilter
    spec = importlib.util.find_spec("filterpy")   # locates the package without executing its __init__
    if spec is None or spec.origin is None:
        raise ImportError("filterpy is not installed")
    root = Path(spec.origin).parent
    pkg = types.ModuleType("filterpy")
    pkg.__path__ = []                     # a package with no submodules of its own: nothing else loads
    stats = types.ModuleType("filterpy.stats")
    stats.logpdf = _lazy_logpdf           # type: ignore[attr-defined]
    common = _exec_file("filterpy.common.helpers", root / "common" / "helpers.py")
    stand_ins = {"filterpy": pkg, "filterpy.stats": stats, "filterpy.common": common}
    saved = {k: sys.modules[k] for k in stand_ins if k in sys.modules}
    sys.modules.update(stand_ins)
    try:
        ekf = _exec_file("filterpy.kalman.EKF", root / "kalman" / "EKF.py")
    finally:
        for k in stand_ins:
            sys.modules.pop(k, None)
        sys.modules.update(saved)
    return ekf.ExtendedKalmanFilter


ExtendedKalmanFilter = _load()
