"""How to rerun a run: the package version, the git commit, and the ``run.json`` record each run folder gets.

``run.json`` holds the exact command line, the working directory, the resolved configs (sea,
mission, vehicle), every firmware parameter (with the overrides marked), the seed, the
version and the commit — enough to rerun the run and to see what it was.
"""
from __future__ import annotations

import json
import os
import shlex
import sys
from pathlib import Path
from typing import Any

from bridge.version import git_commit, package_version

__all__ = ["git_commit", "package_version", "run_record", "version_string", "write_run_record"]

ROOT = Path(__file__).resolve().parents[2]


def version_string() -> str:
    commit = git_commit()
    return f"wavekeep {package_version()}" + (f" (git {commit})" if commit else "")


def run_record(argv: list[str], spec: Any = None, seed: int | None = None, **extra: Any) -> dict[str, Any]:
    """The record of one run (see the module docstring); ``spec`` a RunSpec, or None (then only what is given)."""
    doc: dict[str, Any] = {
        "command": shlex.join(["wavekeep", *argv]), "argv": list(argv), "cwd": os.getcwd(),
        "version": package_version(), "git_commit": git_commit(), "python": sys.version.split()[0], "seed": seed,
    }
    if spec is not None:
        from bridge.schemas import load_mission_config, load_true_vehicle, load_vehicle_config
        from firmware_py.params import load_params
        from sitl.sea import load_sea_config

        params = load_params()
        for name, value in spec.overrides.items():
            params.set(name, value)
        configs = {"sea": load_sea_config(spec.case, spec.sea), "mission": load_mission_config(spec.mission),
                   "vehicle": load_vehicle_config(spec.vehicle)}
        if spec.true_vehicle:
            configs["true_vehicle"] = load_true_vehicle(spec.true_vehicle)
        doc.update(spec=spec.as_record(),
                   configs=configs,
                   parameters=params.as_dict(), parameter_overrides=dict(spec.overrides))
    doc.update(extra)
    return doc


def write_run_record(out: str | Path, argv: list[str], spec: Any = None, seed: int | None = None,
                     **extra: Any) -> Path:
    """DIR/run.json (see :func:`run_record`)."""
    path = Path(out) / "run.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(run_record(argv, spec, seed, **extra), indent=2, default=str))
    return path
