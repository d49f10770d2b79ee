"""The harness: the one place that wires the vehicle (``firmware_py``) to the world (``sitl``).

In-process runs, the multi-process launcher, live runs, the paper's table,
campaigns, metrics, figures and the ``wavekeep`` command line live here.
"""
