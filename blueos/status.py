"""What the page shows: the link, engaged or not, the forecast's age and skill, the law and its live errors.

Read from the web server's thread while the control task runs: every value is one attribute read (a
reference or a number), so a snapshot may mix two ticks, never a torn value. Non-finite numbers are None
(JSON has no NaN).
"""
from __future__ import annotations

import contextlib
import math
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from firmware_py.companion.autopilot import SUB_MODES

from .settings import LAWS

__all__ = ["status"]


def _num(v: float | None, digits: int = 3) -> float | None:
    return None if v is None or not math.isfinite(v) else round(float(v), digits)


def _link(service, now: float) -> dict[str, Any]:
    link = service.link
    st = link.state if link is not None else None
    att = st.samples.get("ATTITUDE") if st is not None else None
    age = now - att.arrived if att is not None else None
    ok = age is not None and age <= service.options.stale_s
    return {"ok": ok, "endpoint": service.options.mavlink, "phase": service.phase, "detail": service.detail,
            "attitude_age_s": _num(age), "heartbeat_age_s": _num(now - st.heartbeat_at) if st is not None else None,
            "armed": bool(st.armed) if st is not None else None,
            "mode": SUB_MODES.get(st.mode, str(st.mode)) if st is not None and st.mode is not None else None,
            "router_endpoint": service.endpoint}


def _forecast(service, now: float) -> dict[str, Any]:
    fw, settings = service.fw, service.settings
    out: dict[str, Any] = {"needed": settings.needs_forecast, "endpoint": settings.forecast_endpoint,
                           "site": settings.site, "ok": False, "age_s": None, "skill": None, "ff_active": False}
    if fw is None or not settings.needs_forecast:
        return out
    last, newest = fw.last, fw.forecast.newest()
    seen = service.forecast_seen[1]
    out["age_s"] = _num(now - seen, 1) if newest is not None and math.isfinite(seen) else None
    out["ok"] = bool(newest is not None and last is not None and newest.is_valid_at(last.t))
    if last is not None:
        out["skill"] = [_num(v) for v in np.asarray(last.ff_skill, dtype=float)]
        out["ff_active"] = bool(last.ff_active)
    return out


def _control(service) -> dict[str, Any]:
    fw, c = service.fw, service.commander
    out: dict[str, Any] = {"law": LAWS[service.settings.law], "gains": service.settings.gains,
                           "method": service.settings.method, "engaged": bool(c is not None and c.engaged),
                           "depth_only": bool(c is not None and c.depth_only), "errors": None}
    last = fw.last if fw is not None else None
    if last is not None and out["engaged"]:
        e = np.asarray(last.x_hat[:3], dtype=float) - np.asarray(last.setpoint, dtype=float)
        out["errors"] = {"x_m": _num(e[0]), "z_m": _num(e[1]), "pitch_deg": _num(math.degrees(e[2]), 2)}
    return out


def _process(service) -> dict[str, Any]:
    """This process's CPU time (s, user + system), resident memory now and at its peak (MB), and its control ticks:
    what the container's limits bound."""
    t = os.times()
    kb: dict[str, float] = {}
    with contextlib.suppress(OSError):
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith(("VmRSS:", "VmHWM:")):
                kb[line[:5]] = float(line.split()[1])
    mb = {k: _num(v / 1024.0, 1) for k, v in kb.items()}
    return {"cpu_s": round(t.user + t.system, 3), "rss_mb": mb.get("VmRSS"), "rss_peak_mb": mb.get("VmHWM"),
            "ticks": service.ticks}


def status(service) -> dict[str, Any]:
    """The page's snapshot of a :class:`~blueos.service.CompanionService` (JSON-ready)."""
    now = time.monotonic()
    c = service.commander
    events = [text for _t, text in list(c.events)[-8:]] if c is not None else []
    return {"headline": service.status_line(), "link": _link(service, now), "forecast": _forecast(service, now),
            "control": _control(service), "events": events, "settings": service.settings.as_dict(),
            "settings_error": service.settings_error, "process": _process(service)}
