"""Fixtures shared across test modules.

The MAVLink tests fly one live vehicle per module (``v``: plant, firmware and
link on the wall clock, a pymavlink ground station on real UDP); the
fixtures are defined in :mod:`mavlink_gcs` with the ground-station helpers and
registered here, so that no test module imports a fixture by name.
"""
from mavlink_gcs import _restore, fast_heartbeat, fast_servo, v  # noqa: F401  (fixtures: registered by import)
