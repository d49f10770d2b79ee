"""A campaign: a grid of missions (sea states × seeds × controller variants) declared in one YAML file.

The file is validated in :mod:`bridge.configfile`'s style: every key known, every
value checked, and a :class:`~bridge.configfile.ConfigError` naming the file and
the dotted key (``variants[2].snr_db``, ``seeds.to``) for anything wrong. The grid
expands to one :class:`CampaignTask` per mission, each carrying the
:class:`~sitl.harness.spec.RunSpec` that ``run_mission`` takes::

    name: paper_30_seeds
    cases: [W1, W2, W3]            # names in configs/sea/ or sea YAML paths (relative to this file)
    seeds: {from: 1, to: 30}       # or a list: [1, 2, 3]
    duration: 600                  # s per mission (default: the mission config's)
    mission: station_keeping
    vehicle: bluerov2_heavy
    baseline: cpd                  # the variant the others are compared with
    bootstrap: {resamples: 10000, seed: 0}
    variants:
      - {name: cpd, controller: cpd}
      - {name: ff_exact, controller: cpd_ff, forecast: oracle}
      - {name: ff_15db, controller: cpd_ff, forecast: oracle, snr_db: 15, overrides: {WK_FF_GAIN: 1.0}}

Parameter overrides are checked here against the firmware's parameter table, as
``wavekeep run --set`` checks them: an unknown name or a value out of its range is a
ConfigError naming the dotted key (``variants[2].overrides.WK_FF_GAN``), before any
mission flies.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import re
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from bridge.configfile import ConfigError, Field, read_yaml, validate

from .spec import CONTROLLERS, FORECAST_SOURCES, MAX_SEED, RunSpec

__all__ = ["CAMPAIGN_SCHEMA", "CampaignSpec", "CampaignTask", "Variant", "load_campaign_spec", "spec_hash"]

MAX_MISSIONS = 1_000_000
_PARAM_NAME = re.compile(r"^WK_[A-Z0-9_]+$")

_VARIANT_ITEM = {
    "name": Field("str", doc="the variant's name in tables, figures and mission ids"),
    "controller": Field("choice", choices=CONTROLLERS),
    "forecast": Field("choice", choices=FORECAST_SOURCES, default="oracle", required=False),
    "snr_db": Field("float", lo=-20.0, hi=80.0, required=False, doc="oracle forecast error (dB); absent: exact"),
    "true_vehicle": Field("str", required=False, doc="plant-only vehicle override in configs/vehicle/true/"),
    "baseline": Field("str", required=False, doc="this variant's own baseline (default: the campaign's)"),
}
_BY_HAND = ("overrides", "sea", "dswp")
"""Variant keys holding free mappings, checked by hand: parameters, sea config keys, DSWP options."""

CAMPAIGN_SCHEMA = {
    "name": Field("str", default="campaign", required=False),
    "cases": Field("list_str", doc="sea states: names in configs/sea/ or YAML paths"),
    "duration": Field("float", lo=0.0, lo_open=True, hi=86400.0, required=False, doc="s per mission"),
    "mission": Field("str", default="station_keeping", required=False),
    "vehicle": Field("str", default="bluerov2_heavy", required=False),
    "baseline": Field("str", doc="the name of the variant the others are compared with"),
    "bootstrap": {
        "resamples": Field("int", lo=100, hi=1_000_000, default=10_000, required=False),
        "seed": Field("int", lo=0, hi=MAX_SEED, default=0, required=False),
    },
    "variants": Field("list", item=_VARIANT_ITEM),
}
"""The campaign file's schema (``seeds`` and each variant's ``overrides`` are checked by hand: see the module)."""


@dataclass(frozen=True)
class Variant:
    """One controller configuration of the grid."""

    name: str
    controller: str
    forecast: str = "oracle"
    snr_db: float | None = None
    overrides: Mapping[str, float] = field(default_factory=dict)
    sea: Mapping[str, Any] = field(default_factory=dict)       # sea config dotted keys (world errors)
    true_vehicle: str | None = None                             # plant-only vehicle override
    dswp: Mapping[str, Any] = field(default_factory=dict)      # DSWP forecaster options
    baseline: str | None = None                                 # the variant it is compared with (None: campaign's)


@dataclass(frozen=True)
class CampaignTask:
    """One mission of the grid: its id, its variant's name and the RunSpec a worker flies."""

    mission_id: str
    variant: str
    spec: RunSpec
    keep_timeseries: bool = False

    @property
    def spec_hash(self) -> str:
        return spec_hash(self.spec)


@dataclass(frozen=True)
class CampaignSpec:
    """A validated campaign file (see the module docstring)."""

    name: str
    cases: tuple[str, ...]
    seeds: tuple[int, ...]
    variants: tuple[Variant, ...]
    baseline: str
    duration: float | None = None
    mission: str = "station_keeping"
    vehicle: str = "bluerov2_heavy"
    bootstrap_resamples: int = 10_000
    bootstrap_seed: int = 0
    source: str = "<built-in>"

    def tasks(self) -> list[CampaignTask]:
        """Every mission of the grid, case-major then variant then seed (a stable order)."""
        return [CampaignTask(f"{case}:{v.name}:{seed}", v.name,
                             RunSpec(case=case, controller=v.controller, snr_db=v.snr_db, seed=seed,
                                     duration=self.duration, mission=self.mission, vehicle=self.vehicle,
                                     forecast=v.forecast, overrides=dict(v.overrides), sea=dict(v.sea),
                                     true_vehicle=v.true_vehicle, dswp=dict(v.dswp)))
                for case in self.cases for v in self.variants for seed in self.seeds]

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready description (written beside the results)."""
        d = asdict(self)
        d["variants"] = [dict(asdict(v), overrides=dict(v.overrides), sea=dict(v.sea), dswp=dict(v.dswp))
                         for v in self.variants]
        return d


def spec_hash(spec: RunSpec) -> str:
    """A short digest of every RunSpec field: a journal row counts as done only for the same spec."""
    d = spec.as_record()
    return hashlib.sha1(json.dumps(d, sort_keys=True).encode()).hexdigest()[:16]


def _seeds(raw: Any, file: str) -> tuple[int, ...]:
    """``seeds``: a list of integers or ``{from: A, to: B}`` (inclusive)."""
    seed_field = Field("int", lo=0, hi=MAX_SEED)
    if isinstance(raw, Mapping):
        rng = validate(raw, {"from": seed_field, "to": seed_field}, file, "seeds")
        if rng["to"] < rng["from"]:
            raise ConfigError(file, "seeds.to", f"got {rng['to']}; must be >= seeds.from ({rng['from']})")
        if rng["to"] - rng["from"] + 1 > MAX_MISSIONS:
            raise ConfigError(file, "seeds", f"a range of at most {MAX_MISSIONS} seeds")
        return tuple(range(rng["from"], rng["to"] + 1))
    if isinstance(raw, list) and raw:
        seeds = tuple(int(x) for x in raw)
        dup = sorted(s for s, c in Counter(seeds).items() if c > 1)
        if dup:
            raise ConfigError(file, "seeds", f"seed {dup[0]} is listed twice")
        return seeds
    raise ConfigError(file, "seeds", f"got {raw!r:.60}; allowed: a non-empty list of integers "
                      f"in [0, {MAX_SEED}] or {{from: A, to: B}}")


def _bad_seed(file: str, i: int, value: Any) -> None:
    raise ConfigError(file, f"seeds[{i}]", f"got {value!r}; allowed: an integer in [0, {MAX_SEED}]")


def _check_seeds_list(raw: Any, file: str) -> tuple[int, ...]:
    """Like :func:`_seeds`, with list items' errors named ``seeds[i]``."""
    if isinstance(raw, list):
        for i, s in enumerate(raw):
            if isinstance(s, bool) or not isinstance(s, int) or not 0 <= s <= MAX_SEED:
                _bad_seed(file, i, s)
    return _seeds(raw, file)


def _overrides(raw: Any, file: str, key: str) -> dict[str, float]:
    """A variant's ``overrides``: parameter NAME (``WK_*``) → finite number."""
    if raw is None:
        return {}
    if not isinstance(raw, Mapping):
        raise ConfigError(file, key, f"got {raw!r:.60}; allowed: a mapping of WK_* parameter names to numbers")
    from firmware_py.params.table import load_params

    table = load_params()
    out: dict[str, float] = {}
    for name, value in raw.items():
        if not isinstance(name, str) or not _PARAM_NAME.match(name):
            raise ConfigError(file, f"{key}.{name}", "not a parameter name; allowed: WK_ followed by A-Z, 0-9, _")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ConfigError(file, f"{key}.{name}", f"got {value!r}; allowed: a finite number")
        why = table.set(name, float(value))
        if why:
            raise ConfigError(file, f"{key}.{name}", why)
        out[name] = float(value)
    return out


def _flat_mapping(raw: Any, file: str, key: str) -> dict[str, Any]:
    """A mapping of option names to values, nested mappings flattened to dotted keys
    (``{buoy: {dropout: 0.1}}`` and ``{buoy.dropout: 0.1}`` are the same)."""
    if raw is None:
        return {}
    if not isinstance(raw, Mapping):
        raise ConfigError(file, key, f"got {raw!r:.60}; allowed: a mapping of option names to values")
    out: dict[str, Any] = {}
    for name, value in raw.items():
        if isinstance(value, Mapping):
            out.update({f"{name}.{k}": v for k, v in _flat_mapping(value, file, f"{key}.{name}").items()})
        else:
            out[str(name)] = value
    return out


def _check_world(v: Variant, file: str, key: str) -> None:
    """A variant's DSWP options and true vehicle, checked now so a bad one fails the campaign, not its missions."""
    from bridge.schemas import load_true_vehicle
    try:
        RunSpec(controller=v.controller, forecast=v.forecast, dswp=v.dswp)
    except ValueError as exc:
        raise ConfigError(file, f"{key}.dswp", str(exc)) from None
    if v.true_vehicle:
        try:
            load_true_vehicle(v.true_vehicle)
        except ConfigError as exc:
            raise ConfigError(file, f"{key}.true_vehicle", str(exc)) from None


def _check_baselines(variants: Sequence[Variant], file: str) -> None:
    names = {v.name for v in variants}
    for i, v in enumerate(variants):
        if v.baseline is not None and (v.baseline not in names or v.baseline == v.name):
            raise ConfigError(file, f"variants[{i}].baseline", f"got {v.baseline!r}; allowed: another variant's name")


def _check_sea_overrides(variants: Sequence[Variant], cases: Sequence[str], file: str) -> None:
    """Each variant's ``sea`` keys applied to each sea state's config and validated there."""
    from sitl.sea import load_sea_config
    for i, v in enumerate(variants):
        if v.sea:
            for case in cases:
                try:
                    load_sea_config(case, v.sea)
                except ConfigError as exc:
                    raise ConfigError(file, f"variants[{i}].sea", str(exc)) from None


def _case(name: str, base: Path, file: str, key: str) -> str:
    """A sea state name, or a path made absolute (relative paths are taken from the campaign file's folder);
    the sea config is validated here, so a bad one stops the campaign before any mission flies."""
    from sitl.sea import load_sea_config

    p = Path(name)
    if p.suffix in (".yaml", ".yml"):
        p = p if p.is_absolute() or p.exists() else base / p
        if not p.exists():
            raise ConfigError(file, key, f"no such sea file {name!r} (looked in {base})")
        name = str(p.resolve())
    try:
        load_sea_config(name)
    except ConfigError as exc:
        raise ConfigError(file, key, f"{exc.key}: {exc.message}" if exc.key else exc.message) from None
    return name


def _variants(items: Sequence[Mapping[str, Any]], raw_items: list, file: str) -> tuple[Variant, ...]:
    out: list[Variant] = []
    for i, (v, raw) in enumerate(zip(items, raw_items, strict=True)):
        key = f"variants[{i}]"
        if any(v["name"] == o.name for o in out):
            raise ConfigError(file, f"{key}.name", f"variant name {v['name']!r} is used twice")
        if not re.match(r"^[A-Za-z0-9_.+-]+$", v["name"]):
            raise ConfigError(file, f"{key}.name", f"got {v['name']!r}; allowed: letters, digits and _ . + -")
        variant = Variant(v["name"], v["controller"], v["forecast"], v["snr_db"],
                          _overrides(raw.get("overrides"), file, f"{key}.overrides"),
                          _flat_mapping(raw.get("sea"), file, f"{key}.sea"), v["true_vehicle"],
                          _flat_mapping(raw.get("dswp"), file, f"{key}.dswp"), v["baseline"])
        try:
            RunSpec(controller=variant.controller, snr_db=variant.snr_db, forecast=variant.forecast)
        except ValueError as exc:
            raise ConfigError(file, f"{key}.snr_db" if variant.snr_db is not None else f"{key}.forecast",
                              str(exc)) from None
        _check_world(variant, file, key)
        out.append(variant)
    if not out:
        raise ConfigError(file, "variants", "allowed: a non-empty list of variants")
    return tuple(out)


def parse_campaign(data: Any, file: str, base: Path) -> CampaignSpec:
    """Validate a campaign document (already parsed from YAML); ``base`` resolves relative sea paths."""
    if not isinstance(data, Mapping):
        raise ConfigError(file, None, f"expected a mapping, got {type(data).__name__}")
    if "seeds" not in data:
        raise ConfigError(file, "seeds", "missing; required: a list of integers or {from: A, to: B}")
    seeds = _check_seeds_list(data["seeds"], file)
    raw_variants = data.get("variants")
    rest = {k: v for k, v in data.items() if k != "seeds"}
    if isinstance(raw_variants, list):
        rest["variants"] = [{k: x for k, x in v.items() if k not in _BY_HAND} if isinstance(v, Mapping) else v
                            for v in raw_variants]
    cfg = validate(rest, CAMPAIGN_SCHEMA, file)
    variants = _variants(cfg["variants"], raw_variants or [], file)
    if cfg["baseline"] not in {v.name for v in variants}:
        raise ConfigError(file, "baseline", f"got {cfg['baseline']!r}; allowed: one of the variants' names "
                          f"({', '.join(v.name for v in variants)})")
    if not cfg["cases"]:
        raise ConfigError(file, "cases", "allowed: a non-empty list of sea states")
    cases = tuple(_case(c, base, file, f"cases[{i}]") for i, c in enumerate(cfg["cases"]))
    if len(set(cases)) != len(cases):
        raise ConfigError(file, "cases", "a sea state is listed twice")
    _check_baselines(variants, file)
    _check_sea_overrides(variants, cases, file)
    n = len(cases) * len(seeds) * len(variants)
    if n > MAX_MISSIONS:
        raise ConfigError(file, "seeds", f"the grid has {n} missions; at most {MAX_MISSIONS}")
    bs = cfg["bootstrap"]
    return CampaignSpec(cfg["name"], cases, seeds, variants, cfg["baseline"], cfg["duration"], cfg["mission"],
                        cfg["vehicle"], bs["resamples"], bs["seed"], file)


def load_campaign_spec(path: str | os.PathLike) -> CampaignSpec:
    """Read and validate a campaign YAML file; :class:`ConfigError` names the file and the key."""
    path = Path(path)
    return parse_campaign(read_yaml(path), str(path), path.resolve().parent)
