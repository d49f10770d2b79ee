"""Schema and loader of the six-DoF vehicle config (``configs/vehicle/bluerov2_heavy_6dof.yaml``).

Ranges are physical plausibility bounds, as :mod:`bridge.schemas`' for the planar vehicle; an error
names the file, the dotted key and the allowed range (:class:`bridge.configfile.ConfigError`).
"""
from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import cast

import numpy as np

from bridge.configfile import ConfigError, Field, load_config, resolve_config
from bridge.schemas import VEHICLE_SCHEMA, _positive

from .rigid_body6 import RigidBody6Params, rigid_body_mass
from .waves import G

__all__ = ["VEHICLE6_SCHEMA", "load_rigid_body6", "load_vehicle6_config", "rigid_body6_from_vehicle"]


def _coefficients(names: tuple[str, ...], hi: tuple[float, ...], unit: tuple[str, ...]) -> dict:
    return {n: Field("float", lo=0.0, hi=h, doc=u) for n, h, u in zip(names, hi, unit, strict=True)}


_PLANAR_MASS_PROPERTIES = cast("Mapping[str, Field]", VEHICLE_SCHEMA["mass_properties"])
_LIN, _ROT = ("kg", "kg", "kg"), ("kg m^2", "kg m^2", "kg m^2")

VEHICLE6_SCHEMA = {
    "name": Field("str"),
    "mass_properties": {      # the planar vehicle's fields, and the inertias and the beam of the other axes
        **{k: _PLANAR_MASS_PROPERTIES[k]
           for k in ("W", "B", "r_G", "r_B", "length", "height", "displaced_volume", "water_density")},
        "I_x": _positive(1e3, "roll inertia about the CG (kg m^2)"),
        "I_y": _positive(1e3, "pitch inertia about the CG (kg m^2)"),
        "I_z": _positive(1e3, "yaw inertia about the CG (kg m^2)"),
        "beam": _positive(10.0, "body beam (m)"),
    },
    "added_mass": {
        **_coefficients(("X_udot", "Y_vdot", "Z_wdot"), (1e3, 1e3, 1e3), _LIN),
        **_coefficients(("K_pdot", "M_qdot", "N_rdot"), (1e2, 1e2, 1e2), _ROT),
        "X_qdot": Field("float", lo=-1e2, hi=1e2, default=0.0, doc="surge-pitch coupling X_qdot = M_udot (kg m)"),
    },
    "damping": {
        **_coefficients(("X_u", "Y_v", "Z_w"), (1e4, 1e4, 1e4), ("kg/s",) * 3),
        **_coefficients(("K_p", "M_q", "N_r"), (1e3, 1e3, 1e3), ("kg m^2/s",) * 3),
        **_coefficients(("X_uu", "Y_vv", "Z_ww"), (1e4, 1e4, 1e4), ("N s^2/m^2",) * 3),
        **_coefficients(("K_pp", "M_qq", "N_rr"), (1e3, 1e3, 1e3), ("N m s^2",) * 3),
    },
}


def load_vehicle6_config(name_or_path: str | Path = "bluerov2_heavy_6dof") -> dict:
    """Load and validate a six-DoF vehicle config by name (``configs/vehicle/NAME.yaml``) or path.

    Beyond the ranges: the mass matrix M = M_RB + M_A must be positive definite (a large X_q̇ against
    the surge and pitch inertias is not), reported against ``added_mass.X_qdot``.
    """
    path = resolve_config(name_or_path, "vehicle")
    cfg = load_config(path, VEHICLE6_SCHEMA)
    mp, am = cfg["mass_properties"], cfg["added_mass"]
    m = mp["W"] / G
    M = rigid_body_mass(m, np.diag([mp["I_x"], mp["I_y"], mp["I_z"]]), mp["r_G"])
    M += np.diag([am[k] for k in ("X_udot", "Y_vdot", "Z_wdot", "K_pdot", "M_qdot", "N_rdot")])
    M[0, 4] += am["X_qdot"]
    M[4, 0] += am["X_qdot"]
    if np.linalg.eigvalsh(M).min() <= 0.0:
        limit = float(np.sqrt((M[0, 0]) * (M[4, 4])))
        raise ConfigError(path, "added_mass.X_qdot", f"got {am['X_qdot']!r}: the mass matrix is not positive "
                                                     f"definite; allowed: |X_qdot + m z_G| < {limit:.3g} kg m")
    return cfg


def load_rigid_body6(name_or_path: str | Path = "bluerov2_heavy_6dof") -> RigidBody6Params:
    """The six-DoF parameters of ``configs/vehicle/NAME.yaml`` (or a path), validated on load."""
    return RigidBody6Params.from_config(load_vehicle6_config(name_or_path))


def rigid_body6_from_vehicle(vcfg: dict) -> RigidBody6Params:
    """The six-DoF parameters of a validated planar vehicle config (:func:`bridge.schemas.load_vehicle_config`):
    its surge, heave and pitch values and its ``lateral`` section (sway, roll, yaw and the beam).

    What the six-DoF world flies, so that a plant-only true vehicle (which scales the planar config) and the
    firmware's nominal vehicle stay one file; for the shipped vehicle this is
    ``configs/vehicle/bluerov2_heavy_6dof.yaml`` exactly (tested).
    """
    mp, am, dp, lat = vcfg["mass_properties"], vcfg["added_mass"], vcfg["damping"], vcfg["lateral"]
    return RigidBody6Params(
        W=mp["W"], B=mp["B"], I_x=lat["I_x"], I_y=mp["I_y"], I_z=lat["I_z"], r_G=np.array(mp["r_G"]),
        r_B=np.array(mp["r_B"]), length=mp["length"], beam=lat["beam"], height=mp["height"],
        added_mass=np.array([am["X_udot"], lat["Y_vdot"], am["Z_wdot"], lat["K_pdot"], am["M_qdot"], lat["N_rdot"]]),
        X_qdot=am["X_qdot"], linear_damping=np.array([dp["X_u"], lat["Y_v"], dp["Z_w"], lat["K_p"], dp["M_q"],
                                                      lat["N_r"]]),
        quadratic_damping=np.array([dp["X_uu"], lat["Y_vv"], dp["Z_ww"], lat["K_pp"], dp["M_qq"], lat["N_rr"]]),
        displaced_volume=mp.get("displaced_volume"), water_density=mp["water_density"])
