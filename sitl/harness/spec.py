"""What one run is: the run options, in one spec object shared by every way of flying a mission.

:class:`RunSpec` is what ``wavekeep run``, ``wavekeep sim``, ``wavekeep live``,
``wavekeep reproduce`` and campaigns all take: the sea state, the controller,
the forecast source and its error, the seed, the duration, the mission and
vehicle configs, and parameter overrides. It validates itself, so a bad
combination (an SNR given to C-PD, an unknown forecast source) is refused
before anything runs. How a run is carried out (in process, across processes,
on a wall clock) is the caller's business, never the spec's.
"""
from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

from bridge.configfile import ConfigError, Field, validate

__all__ = ["CONTROLLERS", "DSWP_SCHEMA", "FORECAST_SOURCES", "PAPER_CASES", "PAPER_VARIANTS", "RunSpec"]

CONTROLLERS = ("cpd", "cpd_ff", "cpd_dob", "cpd_ff_dob", "mpc")
"""``cpd``: cascaded PD feedback alone; ``cpd_ff``: with the wave feed-forward (paper Eq. 12);
``cpd_dob``, ``cpd_ff_dob``: the same + the aided EKF's disturbance estimate fed back (a disturbance
observer, ``WK_DOB_ENABLE``; docs/estimator.md); ``mpc``: the preview MPC on the forecast's horizon
(``WK_CTRL_LAW`` 1; docs/mpc.md), which flies the C-PD+FF command when a solve fails."""

FORECAST_SOURCES = ("oracle", "dswp")
"""``oracle``: the true sea's components, optionally with the paper's injected error (``snr_db``);
``dswp``: predicted from the up-wave buoy's record (deterministic sea wave prediction)."""

MAX_SEED = 2**63 - 1

DSWP_SCHEMA = {
    "window_s": Field("float", lo=30.0, hi=600.0, default=120.0, doc="s of buoy record fitted"),
    "f_min": Field("float", lo=0.01, hi=1.0, default=0.05, doc="Hz, lower edge of the fitted band"),
    "f_max": Field("float", lo=0.05, hi=2.0, default=0.5, doc="Hz, upper edge of the fitted band"),
    "rel_threshold": Field("float", lo=0.0, lo_open=True, hi=1.0, default=0.05,
                           doc="keep bins above this fraction of the largest in-band amplitude"),
    "deep_water": Field("bool", default=False, doc="predict with k = w^2/g (the authors' deliberate mismatch)"),
    "oversample": Field("int", lo=1, hi=16, default=2, doc="frequencies fitted per DFT bin"),
    "period_s": Field("float", lo=0.05, hi=10.0, default=0.5, doc="s between forecasts"),
    "horizon_s": Field("float", lo=0.0, lo_open=True, hi=60.0, required=False,
                       doc="s past the newest sample; absent: the group-velocity zone"),
}
"""The DSWP forecaster's options (``RunSpec.dswp``, a campaign variant's ``dswp``); the defaults are
the in-process feeder's behaviour before they were options (docs/sea-errors.md gives the reasons)."""


@dataclass(frozen=True)
class RunSpec:
    """One mission's options (see the module docstring). ``snr_db`` is None for the exact forecast."""

    case: str = "W3"
    controller: str = "cpd_ff"
    snr_db: float | None = None
    seed: int | None = None
    duration: float | None = None          # s; None: the mission config's
    mission: str = "station_keeping"
    vehicle: str = "bluerov2_heavy"
    forecast: str = "oracle"
    overrides: Mapping[str, float] = field(default_factory=dict)   # parameter NAME → value
    sea: Mapping[str, Any] = field(default_factory=dict)           # sea config dotted key → value (world errors)
    true_vehicle: str | None = None        # plant-only vehicle override (configs/vehicle/true/); None: nominal
    dswp: Mapping[str, Any] = field(default_factory=dict)          # DSWP option → value (DSWP_SCHEMA)

    def __post_init__(self) -> None:
        if self.controller not in CONTROLLERS:
            raise ValueError(f"controller must be one of {', '.join(CONTROLLERS)}, got {self.controller!r}")
        if self.forecast not in FORECAST_SOURCES:
            raise ValueError(f"forecast must be one of {', '.join(FORECAST_SOURCES)}, got {self.forecast!r}")
        if self.snr_db is not None:
            if not math.isfinite(self.snr_db) or not -20.0 <= self.snr_db <= 80.0:
                raise ValueError(f"forecast SNR must be a finite number of dB in [-20, 80], got {self.snr_db}")
            if not self.ff or self.forecast != "oracle":
                raise ValueError("a forecast SNR applies only to C-PD+FF with the oracle forecast")
        if self.seed is not None and not 0 <= self.seed <= MAX_SEED:
            raise ValueError(f"seed must be in [0, {MAX_SEED}], got {self.seed}")
        if self.duration is not None and not (math.isfinite(self.duration) and self.duration > 0):
            raise ValueError(f"duration must be a positive number of seconds, got {self.duration}")
        object.__setattr__(self, "overrides", dict(self.overrides))
        object.__setattr__(self, "sea", dict(self.sea))
        object.__setattr__(self, "dswp", dict(self.dswp))
        if self.dswp and self.forecast_source != "dswp":
            raise ValueError("DSWP options apply only to C-PD+FF with the dswp forecast")
        self.dswp_options()   # validates
        if self.dob and self.overrides.get("WK_EKF_MODE", 1) != 1:
            raise ValueError("a disturbance observer needs the aided estimator's disturbance states (WK_EKF_MODE 1)")

    @property
    def ff(self) -> bool:
        """Does the firmware use the forecast (the wave feed-forward, or the MPC with its FF fallback)?"""
        return self.controller in ("cpd_ff", "cpd_ff_dob", "mpc")

    @property
    def mpc(self) -> bool:
        """Does the firmware fly the preview MPC?"""
        return self.controller == "mpc"

    def implied_params(self) -> dict[str, float]:
        """The firmware parameters the controller choice sets, on top of the overrides: the law, FF and
        DOB on or off, and the aided estimator, whose disturbance states a disturbance observer feeds back."""
        implied = {"WK_FF_ENABLE": float(self.ff), "WK_DOB_ENABLE": float(self.dob),
                   "WK_CTRL_LAW": float(self.mpc)}
        if self.dob:
            implied["WK_EKF_MODE"] = 1.0
        return implied

    def as_record(self) -> dict[str, Any]:
        """Every field as plain data, less the world-error fields left at their defaults (``sea``,
        ``true_vehicle``, ``dswp``): a spec without them describes itself, and hashes, as before them."""
        d = asdict(self)
        d["overrides"] = dict(sorted(self.overrides.items()))
        for key in ("sea", "true_vehicle", "dswp"):
            if not d[key]:
                del d[key]
        return d

    def dswp_options(self) -> dict[str, Any]:
        """The DSWP forecaster's options: :data:`DSWP_SCHEMA`'s defaults with ``dswp`` on top (validated)."""
        try:
            opts = validate(self.dswp, DSWP_SCHEMA, "<run spec>", "dswp")
        except ConfigError as exc:
            raise ValueError(f"{exc.key}: {exc.message}") from None
        if not opts["f_min"] < opts["f_max"]:
            raise ValueError(f"dswp.f_max: got {opts['f_max']}; must be above dswp.f_min ({opts['f_min']})")
        return opts

    @property
    def dob(self) -> bool:
        """Does the firmware feed the estimated disturbance back (disturbance observer)?"""
        return self.controller.endswith("_dob")

    @property
    def forecast_source(self) -> str | None:
        """Where the forecast comes from (``oracle``/``dswp``), or None for feedback alone."""
        return self.forecast if self.ff else None

    def _param(self, name: str) -> float:
        """The value the firmware flies with: the override, else what the controller choice implies, else
        ``configs/firmware/params.yaml``'s."""
        return self.overrides.get(name, self.implied_params().get(name, _default_params()[name]))

    @property
    def ff_law(self) -> str | None:
        """The feed-forward law flown (``WK_FF_MODE``): ``paper``, ``robust`` or ``wave-velocity``; None without FF."""
        return FF_LAWS.get(int(self._param("WK_FF_MODE")), "?") if self.ff else None

    @property
    def estimator(self) -> str:
        """The estimator flown (``WK_EKF_MODE``): ``paper`` (6 states) or ``aided``."""
        return ESTIMATORS.get(int(self._param("WK_EKF_MODE")), "?")

    @property
    def changed_params(self) -> dict[str, float]:
        """The overrides that differ from ``params.yaml`` and from what the controller choice implies."""
        defaults, implied = _default_params(), self.implied_params()
        return {n: v for n, v in sorted(self.overrides.items())
                if v != implied.get(n, defaults.get(n))}

    @property
    def label(self) -> str:
        """The name in tables and figures: ``C-PD``, ``C-PD+FF exact``, ``C-PD+FF 15 dB``, ``C-PD+FF DSWP``,
        ``MPC exact``, then whatever differs from the defaults — the law (``paper law``), the estimator
        (``paper EKF``), the paper's wave load (``paper's world``), and each other changed parameter
        (``WK_FF_GAIN=0.8``) — so two runs that flew differently never share a label."""
        dob = "+DOB" if self.dob else ""
        law = "MPC" if self.mpc else f"C-PD+FF{dob}"
        if not self.ff:
            base = "C-PD" + dob
        elif self.forecast == "dswp":
            base = f"{law} DSWP"
        else:
            base = f"{law} exact" if self.snr_db is None else f"{law} {self.snr_db:g} dB"
        changed = self.changed_params
        extra = []
        if "WK_FF_MODE" in changed and self.ff and not self.mpc:
            extra.append(f"{self.ff_law} law")
        if "WK_EKF_MODE" in changed:
            extra.append(f"{self.estimator} EKF")
        paper_sea, paper_model = self.sea.get("wave_load") == "paper", changed.get("WK_LOAD_MODEL") == 0
        if paper_sea or paper_model:    # the paper's wave load (docs/models.md): in the world, the firmware, both
            extra.append("paper's world" if paper_sea and paper_model else
                         "paper's sea loads" if paper_sea else "paper's load model")
        extra += [f"{n}={v:g}" for n, v in changed.items() if n not in ("WK_FF_MODE", "WK_EKF_MODE", "WK_LOAD_MODEL")]
        return ", ".join([base, *extra])


FF_LAWS = {0: "paper", 1: "robust", 2: "wave-velocity"}
"""``WK_FF_MODE`` → the law's name in labels and ``results.json`` (docs/feedforward.md)."""

ESTIMATORS = {0: "paper", 1: "aided"}
"""``WK_EKF_MODE`` → the estimator's name (docs/estimator.md)."""


@functools.lru_cache(maxsize=1)
def _default_params() -> dict[str, float]:
    """``configs/firmware/params.yaml``'s values (read once)."""
    from firmware_py.params.table import load_params

    return load_params().as_dict()


PAPER_CASES = ("W1", "W2", "W3")
"""The paper's sea states (Table I)."""

PAPER_VARIANTS = (RunSpec(controller="cpd"), RunSpec(controller="cpd_ff"), RunSpec(controller="cpd_ff", snr_db=15.0))
"""The paper's three controllers: C-PD, C-PD+FF with the exact forecast, and with a 15 dB forecast error."""
