"""One parameter's definition: name, range, units, meaning and storage type (ArduPilot's AP_Param types)."""
from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["INT_TYPE_RANGES", "PARAM_TYPES", "ParamDef"]


INT_TYPE_RANGES: dict[str, tuple[int, int]] = {"INT8": (-128, 127), "INT16": (-32768, 32767),
                                               "INT32": (-2**31, 2**31 - 1)}
"""The storage types of integer parameters (AP_Int8/16/32) and what each holds."""
PARAM_TYPES = ("REAL32", *INT_TYPE_RANGES)


@dataclass(frozen=True)
class ParamDef:
    """Definition of one parameter: name (≤ 16 chars), inclusive range, units, meaning, storage type.

    ``ptype`` is the MAVLink parameter type (ArduPilot's AP_Float / AP_Int8 / AP_Int16 /
    AP_Int32): ``"REAL32"``, ``"INT8"``, ``"INT16"`` or ``"INT32"``. ``integer=True``
    without a ``ptype`` means INT32; an integer ``ptype`` makes the parameter integer.
    ``readonly``: a ground station may read it but not set it (ArduPilot's read-only
    parameters; the configuration file still sets it).
    """

    name: str
    lo: float
    hi: float
    units: str
    doc: str
    integer: bool = False
    ptype: str = ""
    readonly: bool = False
    allowed: frozenset[float] | None = None     # when set, only these values (e.g. a thruster output's functions)

    def __post_init__(self) -> None:
        if not (1 <= len(self.name) <= 16) or self.name.upper() != self.name:
            raise ValueError(f"parameter name {self.name!r} must be 1-16 upper-case characters")
        if not self.lo <= self.hi:
            raise ValueError(f"parameter {self.name}: empty range [{self.lo}, {self.hi}]")
        ptype = self.ptype or ("INT32" if self.integer else "REAL32")
        if ptype not in PARAM_TYPES:
            raise ValueError(f"parameter {self.name}: type {ptype!r} is not one of {', '.join(PARAM_TYPES)}")
        object.__setattr__(self, "ptype", ptype)
        object.__setattr__(self, "integer", ptype != "REAL32")
        if self.integer:
            lo, hi = INT_TYPE_RANGES[ptype]
            if not lo <= self.lo <= self.hi <= hi:
                raise ValueError(f"parameter {self.name}: range [{self.lo}, {self.hi}] does not fit {ptype}")

    def check(self, value: float) -> str | None:
        """Why ``value`` is not allowed, or None."""
        if isinstance(value, bool):
            value = float(value)
        if not isinstance(value, (int, float)) or not math.isfinite(value):
            return f"got {value!r}; allowed: a finite number in [{self.lo:g}, {self.hi:g}]"
        if self.integer and not float(value).is_integer():
            return f"got {value!r}; allowed: an integer in [{self.lo:g}, {self.hi:g}]"
        if not self.lo <= value <= self.hi:
            return f"got {value!r}; allowed: [{self.lo:g}, {self.hi:g}] {self.units}".rstrip()
        if self.allowed is not None and float(value) not in self.allowed:
            return f"got {value!r}; allowed: {', '.join(f'{v:g}' for v in sorted(self.allowed))}"
        return None
