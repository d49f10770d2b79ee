"""Fixtures shared across test modules.

The MAVLink tests fly one live vehicle per module (``v``: plant, firmware and
link on the wall clock, a pymavlink ground station on real UDP); the
fixtures are defined in :mod:`mavlink_gcs` with the ground-station helpers and
registered here, so that no test module imports a fixture by name.
"""
from mavlink_gcs import _restore, fast_heartbeat, fast_servo, v  # noqa: F401  (fixtures: registered by import)


def _file_of(item) -> str:
    return item.nodeid.split("::")[0]


def pytest_collection_modifyitems(config, items):
    """The files that start processes run first, those with the most such tests first of all: ``make test``'s
    workers take one file at a time, so the long files start early and the short ones fill the gaps at the end
    (longest first, the classic rule for the least makespan). A file's tests keep their order."""
    weight: dict[str, int] = {}
    for item in items:
        weight[_file_of(item)] = weight.get(_file_of(item), 0) + bool(item.get_closest_marker("processes"))
    order = {f: i for i, f in enumerate(dict.fromkeys(map(_file_of, items)))}
    items.sort(key=lambda it: (-weight[_file_of(it)], order[_file_of(it)]))


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
