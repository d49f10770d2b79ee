"""Fixtures shared across test modules.

The MAVLink tests fly one live vehicle per module (``v``: plant, firmware and
link on the wall clock, a pymavlink ground station on real UDP); the
fixtures are defined in :mod:`mavlink_gcs` with the ground-station helpers and
registered here, so that no test module imports a fixture by name.
"""
from mavlink_gcs import _restore, fast_heartbeat, fast_servo, v  # noqa: F401  (fixtures: registered by import)


def pytest_configure(config):
    """Once, in the process that hands the tests to ``make test``'s workers (or runs them itself), before any test:
    compile the models' kernels into numba's cache. On a fresh clone the cache is empty, and every worker and
    every process a test starts would otherwise compile the same kernels at once, on two cores."""
    if hasattr(config, "workerinput"):
        return
    from bridge.models import horizon_kernels, kernels, kernels6
    kernels.warm_up()
    horizon_kernels.warm_up()
    kernels6.warm_up6()
