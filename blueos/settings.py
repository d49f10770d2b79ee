"""The settings a pilot changes on the extension's page, validated, and kept as JSON in the data folder.

The file is ``settings.json`` in the folder BlueOS bind-mounts into the container, so it survives a restart
and an update of the extension. A bad file (not JSON, an unknown key, a value out of its choices) is never
flown: :meth:`SettingsStore.load` returns the defaults and the reason, which the page shows.
"""
from __future__ import annotations

import json
import os
import re
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any

from bridge.configfile import ConfigError, configs_dir, read_yaml
from bridge.keys import check_site

__all__ = ["LAWS", "METHODS", "Settings", "SettingsError", "SettingsStore", "gain_presets"]

LAWS = {"cpd": "C-PD", "cpd_ff": "C-PD+FF", "mpc": "preview MPC"}
"""The station-keeping laws the page offers, and their names on it. C-PD needs no forecast; the others do."""
METHODS = ("rc", "servo")
"""How the companion commands ArduSub (docs/companion.md, Commands: two methods)."""
ENDPOINT = re.compile(r"^(tcp|udp|tls|quic)/[A-Za-z0-9_.\-]+:\d{1,5}$")
"""A zenoh endpoint: PROTO/HOST:PORT."""
SETTINGS_FILE = "settings.json"


class SettingsError(ValueError):
    """A setting (or the settings file) is not one the extension can fly; the message says which and why."""


def gain_presets() -> dict[str, dict[str, float]]:
    """The gain presets (``configs/blueos/gains.yaml``): name → firmware parameters to set."""
    path = configs_dir() / "blueos" / "gains.yaml"
    doc = read_yaml(path)
    if not isinstance(doc, dict) or not all(isinstance(v, dict) for v in doc.values()):
        raise ConfigError(path, None, "must map each preset's name to its parameters")
    return {str(k): {str(n): float(x) for n, x in v.items()} for k, v in doc.items()}


@dataclass(frozen=True)
class Settings:
    """What the pilot chooses.

    law : one of :data:`LAWS` (``cpd`` flies without a forecast; ``cpd_ff`` and ``mpc`` need one).
    gains : a preset of ``configs/blueos/gains.yaml``.
    method : ``rc`` (RC overrides of ArduSub's sticks) or ``servo`` (the companion drives the thrusters).
    forecast_endpoint : the zenoh router or forecast service to connect to (PROTO/HOST:PORT).
    site : the forecast's site name (its zenoh keys are ``wavekeep/SITE/...``).
    """

    law: str = "cpd"
    gains: str = "default"
    method: str = "rc"
    forecast_endpoint: str = "tcp/host.docker.internal:7447"
    site: str = "moray"

    @property
    def needs_forecast(self) -> bool:
        return self.law != "cpd"

    def checked(self) -> Settings:
        """These settings, or :class:`SettingsError` naming the first bad one."""
        if self.law not in LAWS:
            raise SettingsError(f"law {self.law!r}: choose one of {', '.join(LAWS)}")
        presets = gain_presets()
        if self.gains not in presets:
            raise SettingsError(f"gains {self.gains!r}: choose one of {', '.join(presets)}")
        if self.method not in METHODS:
            raise SettingsError(f"method {self.method!r}: choose one of {', '.join(METHODS)}")
        if not ENDPOINT.match(self.forecast_endpoint) or not 0 < int(self.forecast_endpoint.rsplit(":", 1)[1]) < 65536:
            raise SettingsError(f"forecast_endpoint {self.forecast_endpoint!r}: give PROTO/HOST:PORT, e.g. "
                                "tcp/host.docker.internal:7447")
        try:
            check_site(self.site)
        except ValueError as exc:
            raise SettingsError(str(exc)) from None
        return self

    @classmethod
    def from_dict(cls, doc: Any) -> Settings:
        """Settings from a JSON object: every key known, every value a string (missing keys take defaults)."""
        if not isinstance(doc, dict):
            raise SettingsError("settings must be a JSON object")
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(doc) - known)
        if unknown:
            raise SettingsError(f"unknown setting {unknown[0]!r}; known: {', '.join(sorted(known))}")
        for key, value in doc.items():
            if not isinstance(value, str):
                raise SettingsError(f"{key}: expected a string, got {json.dumps(value)}")
        return replace(cls(), **doc).checked()

    def as_dict(self) -> dict[str, str]:
        return asdict(self)


class SettingsStore:
    """``settings.json`` in ``folder``: load (validated), save (atomically: a crash leaves the old file)."""

    def __init__(self, folder: str | os.PathLike):
        self.path = Path(folder) / SETTINGS_FILE

    def load(self) -> tuple[Settings, str | None]:
        """The saved settings and None; the defaults and why when there is no valid file (None if none yet)."""
        try:
            text = self.path.read_text(encoding="utf-8")
        except FileNotFoundError:
            return Settings(), None
        except OSError as exc:
            return Settings(), f"{self.path}: cannot read ({exc.strerror}): flying the defaults"
        try:
            return Settings.from_dict(json.loads(text)), None
        except json.JSONDecodeError as exc:
            return Settings(), f"{self.path}: not JSON ({exc.msg} at line {exc.lineno}): flying the defaults"
        except SettingsError as exc:
            return Settings(), f"{self.path}: {exc}: flying the defaults"

    def save(self, settings: Settings) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        tmp = self.path.with_suffix(".tmp")
        tmp.write_text(json.dumps(settings.checked().as_dict(), indent=2) + "\n", encoding="utf-8")
        os.replace(tmp, self.path)
