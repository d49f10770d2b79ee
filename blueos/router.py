"""The companion's endpoint on BlueOS's MAVLink router, registered through BlueOS's ArduPilot manager.

The extension runs on Docker's bridge network, so it cannot reach the router's loopback-only TCP link (5777).
It asks the router for a UDP server endpoint instead (``udpin`` on 0.0.0.0:PORT on the vehicle's computer):
the companion sends to host.docker.internal:PORT (``udpout``) and the router answers to where its datagrams
came from. The endpoint is persistent, so it is there after a reboot; registering again finds it and does
nothing. Vehicle → MAVLink Endpoints in BlueOS shows it (and sets it by hand where this fails).
"""
from __future__ import annotations

import json
import urllib.error
import urllib.request
from typing import Any

__all__ = ["ENDPOINT_NAME", "endpoint_body", "mavlink_port", "register_endpoint"]

ENDPOINT_NAME = "wavekeep"
HTTP_TIMEOUT_S = 5.0


def mavlink_port(url: str) -> int:
    """The UDP port of a ``udpout:HOST:PORT`` endpoint (ValueError for any other kind)."""
    kind, _, rest = url.partition(":")
    host, _, port = rest.rpartition(":")
    if kind != "udpout" or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ValueError(f"{url!r}: registering a router endpoint needs udpout:HOST:PORT")
    return int(port)


def endpoint_body(port: int) -> list[dict[str, Any]]:
    """The ArduPilot manager's endpoint list (``POST .../endpoints``) for the router's UDP server on ``port``."""
    return [{"name": ENDPOINT_NAME, "owner": ENDPOINT_NAME, "connection_type": "udpin", "place": "0.0.0.0",
             "argument": int(port), "persistent": True, "protected": False, "enabled": True}]


def _http(url: str, body: Any = None) -> tuple[int, str]:
    data = None if body is None else json.dumps(body).encode()
    req = urllib.request.Request(url, data=data, method="GET" if body is None else "POST",
                                 headers={"Content-Type": "application/json", "Accept": "application/json"})
    try:
        with urllib.request.urlopen(req, timeout=HTTP_TIMEOUT_S) as r:
            return r.status, r.read().decode(errors="replace")
    except urllib.error.HTTPError as exc:
        return exc.code, exc.read().decode(errors="replace")


def register_endpoint(api_url: str, port: int) -> str:
    """Make sure the router has the UDP server endpoint on ``port``; what happened, in a few words."""
    try:
        code, text = _http(api_url)
        if code == 200:
            known = json.loads(text)
            if any(e.get("connection_type") == "udpin" and int(e.get("argument") or 0) == port for e in known):
                return f"router endpoint udpin:0.0.0.0:{port} present"
        code, text = _http(api_url, endpoint_body(port))
    except (urllib.error.URLError, OSError, ValueError) as exc:
        return f"BlueOS not reachable at {api_url} ({getattr(exc, 'reason', exc)}): set the endpoint by hand"
    if 200 <= code < 300:
        return f"router endpoint udpin:0.0.0.0:{port} registered"
    return f"router endpoint not registered: HTTP {code} {text[:200]}"
