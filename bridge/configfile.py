"""Validated YAML configuration files.

Every file under ``configs/`` is read through :func:`load_config` with a schema:
a nested dict whose leaves are :class:`Field` specs. Loading checks that every
key is known, every required key is present and every value has the right type,
shape and range, and raises :class:`ConfigError` naming the file, the dotted key
and what is allowed. Nothing is returned half-validated.
"""
from __future__ import annotations

import copy
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

__all__ = ["ConfigError", "Field", "apply_overrides", "configs_dir", "load_config", "parse_key_values", "read_yaml",
           "resolve_config", "validate"]


class ConfigError(ValueError):
    """A configuration file is missing, unreadable or holds a bad value."""

    def __init__(self, file: str | os.PathLike | None, key: str | None, message: str):
        self.file = str(file) if file is not None else "<config>"
        self.key = key
        self.message = message
        where = f"{self.file}: key '{key}'" if key else self.file
        super().__init__(f"{where}: {message}")


@dataclass(frozen=True)
class Field:
    """One leaf of a config schema.

    kind: ``"float"``, ``"int"``, ``"bool"``, ``"str"``, ``"floats"`` (a list of
    numbers, optionally of fixed ``length``), ``"choice"`` (a string among
    ``choices``), ``"list_str"`` (a list of non-empty strings) or ``"list"`` (a
    list of mappings each validated by ``item``).
    ``lo``/``hi`` bound numbers (inclusive unless ``lo_open``/``hi_open``).
    """

    kind: str
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    default: Any = None
    required: bool = True
    length: int | None = None
    min_length: int | None = None
    choices: tuple[str, ...] = ()
    item: Mapping[str, Any] | None = None
    doc: str = ""

    def allowed(self) -> str:
        if self.kind == "choice":
            return "one of " + ", ".join(repr(c) for c in self.choices)
        if self.kind == "bool":
            return "true or false"
        if self.kind == "str":
            return "a string"
        lo = "-inf" if self.lo is None else f"{self.lo:g}"
        hi = "inf" if self.hi is None else f"{self.hi:g}"
        rng = f"{'(' if self.lo_open else '['}{lo}, {hi}{')' if self.hi_open else ']'}"
        if self.kind == "floats":
            n = f"{self.length} " if self.length else (f"at least {self.min_length} " if self.min_length else "")
            return f"a list of {n}finite numbers in {rng}"
        if self.kind == "int":
            return f"an integer in {rng}"
        if self.kind == "list":
            return "a list of mappings"
        if self.kind == "list_str":
            return "a list of strings"
        return f"a finite number in {rng}"


def _check_number(value: Any, spec: Field, file, key: str, integer: bool) -> float | int:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(file, key, f"got {value!r}; allowed: {spec.allowed()}")
    if integer and not (isinstance(value, int) or float(value).is_integer()):
        raise ConfigError(file, key, f"got {value!r}; allowed: {spec.allowed()}")
    v = int(value) if integer else float(value)
    if not math.isfinite(v):
        raise ConfigError(file, key, f"got {value!r}; allowed: {spec.allowed()}")
    below = spec.lo is not None and (v <= spec.lo if spec.lo_open else v < spec.lo)
    above = spec.hi is not None and (v >= spec.hi if spec.hi_open else v > spec.hi)
    if below or above:
        raise ConfigError(file, key, f"got {value!r}; allowed: {spec.allowed()}")
    return v


def _check_leaf(value: Any, spec: Field, file, key: str) -> Any:
    if spec.kind == "float":
        return _check_number(value, spec, file, key, integer=False)
    if spec.kind == "int":
        return _check_number(value, spec, file, key, integer=True)
    if spec.kind == "bool":
        if not isinstance(value, bool):
            raise ConfigError(file, key, f"got {value!r}; allowed: {spec.allowed()}")
        return value
    if spec.kind == "str":
        if not isinstance(value, str) or not value:
            raise ConfigError(file, key, f"got {value!r}; allowed: {spec.allowed()}")
        return value
    if spec.kind == "choice":
        if value not in spec.choices:
            raise ConfigError(file, key, f"got {value!r}; allowed: {spec.allowed()}")
        return value
    if spec.kind == "floats":
        if not isinstance(value, (list, tuple)):
            raise ConfigError(file, key, f"got {value!r}; allowed: {spec.allowed()}")
        if spec.length is not None and len(value) != spec.length:
            raise ConfigError(file, key, f"got {len(value)} values; allowed: {spec.allowed()}")
        if spec.min_length is not None and len(value) < spec.min_length:
            raise ConfigError(file, key, f"got {len(value)} values; allowed: {spec.allowed()}")
        return [
            _check_number(v, spec, file, f"{key}[{i}]", integer=False) for i, v in enumerate(value)
        ]
    if spec.kind == "list_str":
        if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
            raise ConfigError(file, key, f"got {value!r:.60}; allowed: {spec.allowed()}")
        return list(value)
    if spec.kind == "list":
        if not isinstance(value, list) or (spec.length is not None and len(value) != spec.length):
            n = f"exactly {spec.length} " if spec.length is not None else ""
            raise ConfigError(file, key, f"got {value!r:.60}; allowed: a list of {n}mappings")
        return [validate(v, spec.item or {}, file, f"{key}[{i}]") for i, v in enumerate(value)]
    raise AssertionError(f"unknown field kind {spec.kind!r}")


def validate(data: Any, schema: Mapping[str, Any], file=None, prefix: str = "") -> dict:
    """Validate ``data`` against ``schema``; return a new dict with defaults filled in."""
    if data is None:
        data = {}
    if not isinstance(data, Mapping):
        raise ConfigError(file, prefix or None, f"expected a mapping, got {type(data).__name__}")
    unknown = sorted(set(data) - set(schema))
    if unknown:
        key = f"{prefix}.{unknown[0]}" if prefix else str(unknown[0])
        raise ConfigError(file, key, f"unknown key; allowed keys here: {', '.join(sorted(schema))}")
    out: dict[str, Any] = {}
    for name, spec in schema.items():
        key = f"{prefix}.{name}" if prefix else name
        if isinstance(spec, Mapping):
            out[name] = validate(data.get(name), spec, file, key)
            continue
        if name not in data:
            if spec.required and spec.default is None:
                raise ConfigError(file, key, f"missing; required: {spec.allowed()}")
            out[name] = spec.default
            continue
        out[name] = _check_leaf(data[name], spec, file, key)
    return out


def read_yaml(path: str | os.PathLike) -> Any:
    """The parsed YAML document in a file; :class:`ConfigError` for a file that is missing or not YAML."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(path, None, f"cannot read: {exc.strerror or exc}") from None
    doc = _PARSED.get(text)
    if doc is None:
        try:
            doc = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise ConfigError(path, None, f"not valid YAML: {exc}") from None
        if len(_PARSED) >= _PARSED_MAX:
            _PARSED.clear()
        _PARSED[text] = doc
    return copy.deepcopy(doc)


_PARSED: dict[str, Any] = {}
""":func:`read_yaml`'s parsed documents, keyed by the file's text (so an edited file is parsed again):
a campaign worker builds each mission from the same six configs, and PyYAML's pure-Python parser
took ≈ 0.2 s of every mission's set-up. Callers get a deep copy."""
_PARSED_MAX = 256


def apply_overrides(data: Any, overrides: Mapping[str, Any] | None, file=None) -> Any:
    """A copy of a parsed config document with dotted keys (``buoy.dropout``) set to new values.

    Intermediate mappings are created as needed; the result is validated by the caller, so an
    unknown key or a bad value is reported like one written in the file. No overrides: ``data``.
    """
    if not overrides:
        return data
    out = copy.deepcopy(data) if data is not None else {}
    if not isinstance(out, dict):
        raise ConfigError(file, None, f"expected a mapping, got {type(out).__name__}")
    for dotted, value in overrides.items():
        parts = str(dotted).split(".")
        node = out
        for i, part in enumerate(parts[:-1]):
            nxt = node.setdefault(part, {})
            if not isinstance(nxt, dict):
                raise ConfigError(file, ".".join(parts[:i + 1]), "is a value, not a section; cannot override below it")
            node = nxt
        node[parts[-1]] = value
    return out


def load_config(path: str | os.PathLike, schema: Mapping[str, Any]) -> dict:
    """Read a YAML file and validate it against ``schema``.

    Raises :class:`ConfigError` (a ``ValueError``) for a missing file, bad YAML or
    any bad value; the message names the file and the key.
    """
    return validate(read_yaml(path), schema, Path(path))


def configs_dir() -> Path:
    """The project's ``configs/`` folder (``$WAVEKEEP_CONFIGS`` overrides)."""
    env = os.environ.get("WAVEKEEP_CONFIGS")
    if env:
        return Path(env)
    here = Path(__file__).resolve().parent.parent / "configs"
    if here.is_dir():
        return here
    return Path.cwd() / "configs"


def resolve_config(name_or_path: str | os.PathLike, kind: str) -> Path:
    """Turn ``W1`` into ``configs/sea/W1.yaml``; pass an existing path through.

    ``kind`` is the sub-folder of ``configs/`` (``sea``, ``vehicle``, ``mission``).
    """
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml") or p.exists():
        if not p.exists():
            raise ConfigError(p, None, "no such file")
        return p
    folder = configs_dir() / kind
    candidate = folder / f"{name_or_path}.yaml"
    if candidate.exists():
        return candidate
    known: Sequence[str] = sorted(q.stem for q in folder.glob("*.yaml")) if folder.is_dir() else []
    raise ConfigError(
        candidate, None,
        f"no {kind} config named {str(name_or_path)!r}; known: {', '.join(known) or 'none'}, "
        "or give a path to a .yaml file",
    )


def parse_key_values(items: Sequence[str] | None) -> dict[str, Any]:
    """Command-line ``KEY=VALUE`` items as a dict, each value read as YAML (``10``, ``0.3``, ``true``).

    ValueError names the item that is not ``KEY=VALUE`` or whose value is not YAML.
    """
    out: dict[str, Any] = {}
    for item in items or []:
        key, eq, text = item.partition("=")
        if not eq or not key.strip():
            raise ValueError(f"{item}: expected KEY=VALUE")
        try:
            out[key.strip()] = yaml.safe_load(text)
        except yaml.YAMLError:
            raise ValueError(f"{item}: {text!r} is not a value") from None
    return out
