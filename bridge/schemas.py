"""Schemas and loaders for the vehicle and mission configs (``configs/vehicle``, ``configs/mission``).

Ranges are physical plausibility bounds, wide enough for any small ROV and tight
enough to catch a slipped unit or sign. See :mod:`bridge.configfile` for the
error format.
"""
from __future__ import annotations

import copy
from pathlib import Path

from bridge.configfile import ConfigError, Field, load_config, resolve_config

__all__ = ["MISSION_SCHEMA", "TRUE_VEHICLE_SCHEMA", "VEHICLE_SCHEMA", "apply_true_vehicle", "load_mission_config",
           "load_true_vehicle", "load_vehicle_config"]



def _positive(hi: float, doc: str = "") -> Field:
    """A float in (0, hi]."""
    return Field("float", lo=0.0, lo_open=True, hi=hi, doc=doc)


_THRUSTER_ITEM = {
    "name": Field("str"),
    "position": Field("floats", lo=-2.0, hi=2.0, length=3, doc="body FRD position (m)"),
    "direction": Field("floats", lo=-1.0, hi=1.0, length=3, doc="positive-thrust direction, body FRD"),
}

VEHICLE_SCHEMA = {
    "name": Field("str"),
    "mass_properties": {
        "W": _positive(1e5, "weight (N)"),
        "B": _positive(1e5, "buoyancy (N)"),
        "I_y": _positive(1e3, "pitch inertia (kg m^2)"),
        "r_G": Field("floats", lo=-1.0, hi=1.0, length=3),
        "r_B": Field("floats", lo=-1.0, hi=1.0, length=3),
        "length": _positive(10.0, "body length L (m)"),
        "height": _positive(10.0, "body height (m)"),
        # The Froude–Krylov force ρ∇·a of the wave's pressure gradient acts on the displaced water
        "displaced_volume": Field("float", lo=0.0, lo_open=True, hi=100.0, required=False,
                                  doc="m^3; absent: B / (rho g), the volume the buoyancy implies"),
        "water_density": Field("float", lo=990.0, hi=1050.0, default=1025.0, doc="kg/m^3"),
    },
    "added_mass": {
        "X_udot": Field("float", lo=0.0, hi=1e3),
        "Z_wdot": Field("float", lo=0.0, hi=1e3),
        "M_qdot": Field("float", lo=0.0, hi=1e2),
        "X_qdot": Field("float", lo=-1e2, hi=1e2),
    },
    "damping": {
        "X_u": Field("float", lo=0.0, hi=1e4),
        "Z_w": Field("float", lo=0.0, hi=1e4),
        "M_q": Field("float", lo=0.0, hi=1e3),
        "X_uu": Field("float", lo=0.0, hi=1e4),
        "Z_ww": Field("float", lo=0.0, hi=1e4),
        "M_qq": Field("float", lo=0.0, hi=1e3),
    },
    # Sway, roll and yaw and the beam: the six-DoF world uses them (sitl/plant.py, dof "six"). The defaults are the
    # BlueROV2 Heavy's (von Benzon et al. 2022, Table A1; configs/vehicle/bluerov2_heavy_6dof.yaml gives the sources)
    "lateral": {
        "beam": Field("float", lo=0.0, lo_open=True, hi=10.0, default=0.575, doc="body beam (m), spans the strips"),
        "I_x": Field("float", lo=0.0, lo_open=True, hi=1e3, default=0.26, doc="roll inertia (kg m^2)"),
        "I_z": Field("float", lo=0.0, lo_open=True, hi=1e3, default=0.37, doc="yaw inertia (kg m^2)"),
        "Y_vdot": Field("float", lo=0.0, hi=1e3, default=7.12, doc="sway added mass (kg)"),
        "K_pdot": Field("float", lo=0.0, hi=1e2, default=0.189, doc="roll added inertia (kg m^2)"),
        "N_rdot": Field("float", lo=0.0, hi=1e2, default=0.222, doc="yaw added inertia (kg m^2)"),
        "Y_v": Field("float", lo=0.0, hi=1e4, default=0.0, doc="sway linear damping (kg/s)"),
        "K_p": Field("float", lo=0.0, hi=1e3, default=0.0, doc="roll linear damping (kg m^2/s)"),
        "N_r": Field("float", lo=0.0, hi=1e3, default=0.0, doc="yaw linear damping (kg m^2/s)"),
        "Y_vv": Field("float", lo=0.0, hi=1e4, default=217.0, doc="sway quadratic damping (N s^2/m^2)"),
        "K_pp": Field("float", lo=0.0, hi=1e3, default=1.19, doc="roll quadratic damping (N m s^2)"),
        "N_rr": Field("float", lo=0.0, hi=1e3, default=1.5, doc="yaw quadratic damping (N m s^2)"),
    },
    "thrusters": {
        "thrust_max": _positive(500.0, "controller cap per thruster (N)"),
        "time_constant": _positive(5.0, "first-order motor lag (s)"),
        "pwm_min": Field("float", lo=800.0, hi=1500.0),
        "pwm_max": Field("float", lo=1500.0, hi=2200.0),
        "pwm_neutral": Field("float", lo=1400.0, hi=1600.0),
        "curve": {
            "pwm_us": Field("floats", lo=800.0, hi=2200.0, min_length=4),
            "thrust_kgf": Field("floats", lo=-50.0, hi=50.0, min_length=4),
        },
        "layout": Field("list", length=8, item=_THRUSTER_ITEM),
    },
}

MISSION_SCHEMA = {
    "name": Field("str"),
    "setpoint": {
        "x": Field("float", lo=-1e4, hi=1e4, doc="north position (m)"),
        "depth": Field("float", lo=0.5, hi=50.0, doc="depth below still water (m)"),
        "pitch": Field("float", lo=-1.0, hi=1.0, doc="pitch (rad)"),
    },
    "duration": _positive(86400.0, "mission length (s)"),
    "control_rate": Field("float", lo=1.0, hi=1000.0, doc="control task rate (Hz)"),
    "plant": {
        "substeps": Field("int", lo=1, hi=100, doc="RK4 steps per control period"),
        "strips": Field("int", lo=1, hi=64, doc="Gauss-Legendre strips for the Eq. 11 pitch integral"),
    },
}


def _factor(doc: str) -> Field:
    return Field("float", lo=0.1, hi=10.0, default=1.0, doc=doc)


_SCALED = {"added_mass": ("X_udot", "Z_wdot", "M_qdot", "X_qdot"),
           "damping": ("X_u", "Z_w", "M_q", "X_uu", "Z_ww", "M_qq"),
           "mass_properties": ("B", "r_B")}

TRUE_VEHICLE_SCHEMA = {
    "name": Field("str"),
    "scale": {**{k: _factor(f"x nominal {k}") for k in _SCALED["added_mass"] + _SCALED["damping"]},
              "B": _factor("x nominal buoyancy (the displaced volume)"),
              "r_B": _factor("x nominal centre of buoyancy (both components)")},
}
"""A plant-only "true vehicle" (``configs/vehicle/true/NAME.yaml``): factors on the nominal vehicle's
coefficients, so the simulated vehicle differs from the firmware's model (docs/sea-errors.md)."""


def load_true_vehicle(name_or_path: str | Path) -> dict:
    """Load and validate a true-vehicle override by name (``configs/vehicle/true/NAME.yaml``) or path."""
    return load_config(resolve_config(name_or_path, "vehicle/true"), TRUE_VEHICLE_SCHEMA)


def apply_true_vehicle(vcfg: dict, true_vehicle: dict) -> dict:
    """A copy of a validated vehicle config with the true vehicle's factors applied (plant only)."""
    out = copy.deepcopy(vcfg)
    sc = true_vehicle["scale"]
    for section, keys in _SCALED.items():
        for k in keys:
            v = out[section][k]
            out[section][k] = [sc[k] * x for x in v] if isinstance(v, list) else sc[k] * v
    out["name"] = f"{vcfg['name']}+{true_vehicle['name']}"
    return out


def load_vehicle_config(name_or_path: str | Path = "bluerov2_heavy") -> dict:
    """Load and validate a vehicle config by name (``configs/vehicle/NAME.yaml``) or path."""
    path = resolve_config(name_or_path, "vehicle")
    cfg = load_config(path, VEHICLE_SCHEMA)
    th = cfg["thrusters"]
    if len(th["curve"]["pwm_us"]) != len(th["curve"]["thrust_kgf"]):
        raise ConfigError(path, "thrusters.curve.thrust_kgf", "must have as many values as thrusters.curve.pwm_us")
    if not th["pwm_min"] < th["pwm_neutral"] < th["pwm_max"]:
        raise ConfigError(path, "thrusters.pwm_neutral", "must lie strictly between pwm_min and pwm_max")
    for i, t in enumerate(th["layout"]):
        if sum(v * v for v in t["direction"]) < 1e-12:
            raise ConfigError(path, f"thrusters.layout[{i}].direction", "must be a non-zero vector")
    return cfg


def load_mission_config(name_or_path: str | Path = "station_keeping") -> dict:
    """Load and validate a mission config by name (``configs/mission/NAME.yaml``) or path."""
    return load_config(resolve_config(name_or_path, "mission"), MISSION_SCHEMA)
