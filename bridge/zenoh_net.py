"""Zenoh sessions for the forecast link, configured from ``configs/network.yaml``.

Loopback by default, multicast scouting off (docs/platform-notes.md: zenoh's pitfalls measured
here). The forecast service *listens*; vehicles and the plant *connect* to it,
so with gossip scouting the peers find each other through it. Always close a
session (``with open_session(...) as s:``): a Python-callback handler keeps the
interpreter alive otherwise. Do not fork after opening one.
"""
from __future__ import annotations

import json
from pathlib import Path

from .configfile import Field, load_config, resolve_config
from .keys import check_site

__all__ = ["NETWORK_SCHEMA", "load_network_config", "open_session", "zenoh_config"]

NETWORK_SCHEMA = {
    "site": Field("str"),
    "zenoh": {
        "mode": Field("choice", choices=("peer", "client")),
        "service_listen": Field("list_str", required=False),
        "connect": Field("list_str", required=False),
        "multicast_scouting": Field("bool", default=False),
        "gossip_scouting": Field("bool", default=True),
        "scouting_delay_ms": Field("int", lo=0, hi=10_000, default=0),
    },
}


def load_network_config(name_or_path: str | Path = "network") -> dict:
    """Load ``configs/network.yaml`` (or a path); validates endpoints and the site name."""
    from .configfile import ConfigError
    path = resolve_config(name_or_path, "")
    cfg = load_config(path, NETWORK_SCHEMA)
    try:
        check_site(cfg["site"])
    except ValueError as exc:
        raise ConfigError(path, "site", str(exc)) from None
    for key in ("service_listen", "connect"):
        eps = cfg["zenoh"][key] or []
        for i, ep in enumerate(eps):
            if "/" not in ep or ep.split("/", 1)[0] not in ("tcp", "udp", "tls", "quic", "unixsock-stream"):
                raise ConfigError(path, f"zenoh.{key}[{i}]",
                                  f"got {ep!r}; allowed: PROTO/ADDRESS like tcp/127.0.0.1:7447")
        cfg["zenoh"][key] = list(eps)
    return cfg


def zenoh_config(net: dict, listen: list[str] | None = None, connect: list[str] | None = None):
    """A zenoh.Config for one process: ``listen`` for the service, ``connect`` for the others."""
    import zenoh

    z = net["zenoh"]
    c = zenoh.Config()
    c.insert_json5("mode", json.dumps(z["mode"]))
    c.insert_json5("listen/endpoints", json.dumps(list(listen or [])))
    c.insert_json5("connect/endpoints", json.dumps(list(connect or [])))
    c.insert_json5("scouting/multicast/enabled", json.dumps(bool(z["multicast_scouting"])))
    c.insert_json5("scouting/gossip/enabled", json.dumps(bool(z["gossip_scouting"])))
    c.insert_json5("scouting/delay", json.dumps(int(z["scouting_delay_ms"])))
    return c


def open_session(net: dict, role: str):
    """Open a session as the ``service`` (listens) or a ``vehicle``/``plant`` (connects)."""
    import zenoh

    z = net["zenoh"]
    if role == "service":
        return zenoh.open(zenoh_config(net, listen=z["service_listen"] or ["tcp/127.0.0.1:7447"]))
    return zenoh.open(zenoh_config(net, connect=z["connect"] or ["tcp/127.0.0.1:7447"]))
