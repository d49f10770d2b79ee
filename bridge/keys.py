"""Zenoh key expressions of a Wavekeep site: everything lives under ``wavekeep/<site>/``.

=====================================  =====================================================
key                                    what
=====================================  =====================================================
``wavekeep/<site>/forecast``           the newest forecast (:mod:`bridge.forecast_codec`)
``wavekeep/<site>/forecast/latest``    queryable: answers with the newest forecast
``wavekeep/<site>/buoy/elevation``     the wave buoy's elevation record (:mod:`bridge.buoy_codec`)
``wavekeep/<site>/service/forecast``   liveliness token of the forecast service
=====================================  =====================================================
"""
from __future__ import annotations

import re

__all__ = ["buoy_key", "check_site", "forecast_key", "forecast_latest_key", "service_token_key"]

_SITE = re.compile(r"^[A-Za-z0-9_-]{1,64}$")


def check_site(site: str) -> str:
    """A site name is 1–64 letters, digits, '_' or '-' (no '/', '*', '$' that would change the key's meaning)."""
    if not isinstance(site, str) or not _SITE.match(site):
        raise ValueError(f"site name {site!r}: use 1-64 letters, digits, '_' or '-'")
    return site


def forecast_key(site: str) -> str:
    return f"wavekeep/{check_site(site)}/forecast"


def forecast_latest_key(site: str) -> str:
    return f"wavekeep/{check_site(site)}/forecast/latest"


def buoy_key(site: str) -> str:
    return f"wavekeep/{check_site(site)}/buoy/elevation"


def service_token_key(site: str) -> str:
    return f"wavekeep/{check_site(site)}/service/forecast"
