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

__all__ = ["configs_record", "git_commit", "package_version", "run_record", "version_string", "write_run_record"]

ROOT = Path(__file__).resolve().parents[2]


def version_string() -> str:
    commit = git_commit()
    return f"wavekeep {package_version()}" + (f" (git {commit})" if commit else "")


def run_record(argv: list[str], spec: Any = None, seed: int | None = None, **extra: Any) -> dict[str, Any]:
    """The record of one run (see the module docstring); ``spec`` a RunSpec, a list of them (a run of several
    missions: ``specs``, each case's sea), or None (then only what is given)."""
    doc: dict[str, Any] = {
        "command": shlex.join(["wavekeep", *argv]), "argv": list(argv), "cwd": os.getcwd(),
        "version": package_version(), "git_commit": git_commit(), "python": sys.version.split()[0], "seed": seed,
    }
    if isinstance(spec, list | tuple):     # several runs (reproduce): each spec, each sea, shared mission/vehicle
        first = spec[0]
        doc.update(specs=[s.as_record() for s in spec],
                   configs={**_configs(first), "sea": {s.case: _configs(s)["sea"] for s in spec}},
                   parameters=_parameters(first.overrides), parameter_overrides=dict(first.overrides))
    elif spec is not None:
        doc.update(spec=spec.as_record(), configs=_configs(spec), parameters=_parameters(spec.overrides),
                   parameter_overrides=dict(spec.overrides))
    doc.update(extra)
    return doc


def _configs(spec: Any) -> dict[str, Any]:
    """The resolved sea, mission and vehicle configs (and the true vehicle, if any) a RunSpec flies."""
    return configs_record(spec.case, spec.mission, spec.vehicle, spec.sea, spec.true_vehicle)


def configs_record(case: str, mission: str, vehicle: str, sea: Any = None, true_vehicle: str | None = None) -> dict:
    """The resolved sea (with ``sea`` overrides), mission and vehicle configs, and the true vehicle if given."""
    from bridge.schemas import load_mission_config, load_true_vehicle, load_vehicle_config
    from sitl.sea import load_sea_config

    configs = {"sea": load_sea_config(case, sea), "mission": load_mission_config(mission),
               "vehicle": load_vehicle_config(vehicle)}
    if true_vehicle:
        configs["true_vehicle"] = load_true_vehicle(true_vehicle)
    return configs


def _parameters(overrides: Any) -> dict[str, float]:
    """Every firmware parameter, with ``overrides`` applied."""
    from firmware_py.params.table import load_params

    params = load_params()
    for name, value in overrides.items():
        params.set(name, value)
    return params.as_dict()


def write_run_record(out: str | Path, argv: list[str], spec: Any = None, seed: int | None = None,
                     **extra: Any) -> Path:
    """DIR/run.json (see :func:`run_record`)."""
    path = Path(out) / "run.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(run_record(argv, spec, seed, **extra), indent=2, default=str))
    return path
