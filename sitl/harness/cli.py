"""wavekeep: station keeping for a BlueROV2 Heavy in waves — fly missions, reproduce the paper, fly it live.

    wavekeep run       --case W3 --controller cpd_ff --out runs/W3   # one station-keeping mission
    wavekeep sim       --case W3                                     # the same across processes, over MAVLink
    wavekeep reproduce --out runs/reproduce                          # the paper's nine runs and figures
    wavekeep compare   runs/W3-cpd runs/W3                           # runs side by side
    wavekeep campaign  configs/campaign/smoke.yaml --out runs/smoke  # a grid of missions on Dask, with CIs
    wavekeep live      --mavlink udpout:127.0.0.1:14550              # fly it from a ground station
    wavekeep thrust    --pattern sine --axis heave --arm             # stream thrust demands over MAVLink
    wavekeep sea       --case W1 --duration 1800                     # the realised sea at the vehicle
    wavekeep openloop  --case W3 --out runs/openloop-W3              # the passive vehicle in the sea
    wavekeep view      runs/sim                                      # a run, .rrd or .tlog in the 3-D viewer
    wavekeep tlog      runs/sim/mission.tlog --out runs/tlog         # any tlog's figures and CSV
    wavekeep companion --autopilot udpin:127.0.0.1:14770             # beside a real ArduSub (companion computer)

Every --case takes a name from configs/sea/ or a path to a sea YAML file. Bad input (a bad
option, config or output folder) prints one line `wavekeep CMD: ...` and exits with 2;
Ctrl-C exits with 130. `wavekeep CMD -h` lists every option with its units and default.
"""
from __future__ import annotations

import argparse
import sys

from .blas import use_one_blas_thread
from .commands import compare, live, missions, processes, view, world
from .commands.options import Parser, UsageError

__all__ = ["build_parser", "main"]


class _Version(argparse.Action):
    """``--version``: the package version and git commit (computed only when asked)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        from .provenance import version_string
        print(version_string())
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="wavekeep", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action=_Version, help="print the version and git commit, and exit")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND", parser_class=Parser)
    missions.add_parsers(sub)
    processes.add_parsers(sub)
    compare.add_parsers(sub)
    live.add_parsers(sub)
    world.add_parsers(sub)
    view.add_parsers(sub)
    return parser


DELEGATED = {"plant": "sitl.physics_server", "firmware": "firmware_py.app", "companion": "firmware_py.companion.app"}
"""Subcommands that are programs of their own (separate processes in ``wavekeep sim``)."""


def _command(argv: list[str]) -> str:
    return next((a for a in argv if not a.startswith("-")), "")


def main(argv: list[str] | None = None) -> int:
    use_one_blas_thread()   # before any command imports numpy (sitl/harness/blas.py says why)
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv and argv[0] in DELEGATED:
        import importlib
        return importlib.import_module(DELEGATED[argv[0]]).main(argv[1:])
    prefix = f"wavekeep {_command(argv)}".strip()
    try:
        args = build_parser().parse_args(argv)
        args.argv = argv
        return args.func(args)
    except SystemExit as exc:    # --help, --version
        return exc.code if isinstance(exc.code, int) else 0
    except UsageError as exc:
        print(f"{prefix}: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{prefix}: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:
        from bridge.configfile import ConfigError
        from firmware_py.hal.scheduler import interrupt_in
        if interrupt_in(exc) is not None:    # Ctrl-C inside a compiled kernel's call surfaces as the error it caused
            print(f"{prefix}: interrupted", file=sys.stderr)
            return 130
        if isinstance(exc, ConfigError):
            print(f"{prefix}: config error: {exc}", file=sys.stderr)
            return 2
        if isinstance(exc, TimeoutError | ValueError | RuntimeError | OSError):
            print(f"{prefix}: {exc}", file=sys.stderr)
            return 1
        raise


if __name__ == "__main__":
    sys.exit(main())
