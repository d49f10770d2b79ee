"""The ``wavekeep`` subcommands, one module per group; :mod:`sitl.harness.cli` builds the parser and dispatches.

Each module has ``add_parsers(sub)`` and its ``cmd_*`` handlers; heavy imports (numpy, the
simulator, matplotlib, Dask) happen inside the handlers, so ``wavekeep --help`` stays fast.
"""
