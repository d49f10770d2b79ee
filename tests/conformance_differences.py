"""The documented, deliberate differences between Wavekeep and the real ArduSub (see docs/mavlink.md)."""
from __future__ import annotations

DIFFERENCES: dict[str, str] = {}
