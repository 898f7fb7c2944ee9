"""The ``tether`` command. Thin: parses arguments, calls the library, prints.

Every user error (bad map, bad parameter, target outside the free space) is printed as one line
``tether: error: ...`` on stderr with exit status 2; no traceback.

Each command group lives in its own module of this package and exposes ``register(add)``;
a new group is one line in :data:`GROUPS`.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import traceback
import warnings
from collections.abc import Callable, Sequence

import numpy as np

from tether import __version__
from tether._util.memory import memory_limit
from tether.cli.common import example_path
from tether.errors import TetherError

__all__ = ["GROUPS", "build_parser", "example_path", "main"]

EXIT_OK = 0
EXIT_CHECK_FAILED = 1
EXIT_USAGE = 2
EXIT_INTERNAL = 3

#: Modules of :mod:`tether.cli` that add subcommands, in the order of ``tether --help``.
GROUPS = [
    "maps",
    "motion",
    "strategy",
    "ros",
    "kernel",
    "tracks",
    "follow",
]


class _Parser(argparse.ArgumentParser):
    """argparse whose usage errors are one line: ``tether: error: CMD: ...``."""

    def error(self, message: str) -> None:  # type: ignore[override]
        command = self.prog.partition(" ")[2]
        where = f"{command}: " if command else ""
        _say(f"tether: error: {where}{one_line(message)} (see '{self.prog} --help')")
        raise SystemExit(EXIT_USAGE)


_EX = "src/tether/examples"

#: One example per command, shown by ``tether COMMAND --help``.
EXAMPLES = {
    "demo": "tether demo --out tether-demo",
    "info": f"tether info {_EX}/gallery.json",
    "arcs": f"tether arcs {_EX}/gallery.json --lss 2 --at 9 1.5",
    "decompose": f"tether decompose {_EX}/gallery.wkt --lss 2 --plot gallery.png",
    "analyze": f"tether analyze {_EX}/rectangle.json --lss 1 --json",
    "check": f"tether check {_EX}/gallery.geojson --lss 2 --samples 50 --seed 7",
    "bound": "tether bound --vt 1 --vo 2 --lss 1 --from 0 --to 1.5708",
    "plot-motion": "tether plot-motion wall --vt 1 --vo 2 --lss 1 --out wall.png",
    "assess": f"tether assess {_EX}/gallery.json --lss 2 --vt 0.3 --vo 1 --at 2 2.5 0.5",
    "simulate": (f"tether simulate {_EX}/gallery.json --lss 2 --vt 0.3 --vo 1 --start 2 2.5 0.5 "
                 "--target random --duration 20 --animate run.gif"),
    "kernel": f"tether kernel {_EX}/gallery.json --lss 2 --vt 0.3 --vo 1 --at 2 2.5 0.5 --json",
    "convert": f"tether convert {_EX}/office.yaml office.geojson",
    "sweep": f"tether sweep {_EX}/rectangle.json --lss 0.5:2:0.25",
    "follow": (f"tether follow {_EX}/office.yaml --track person.csv --lss 0.8 --vt 0.3 --vo 1 "
               "--baseline spin --plot follow.png"),
}
EXAMPLES["tracks"] = (f"tether tracks {_EX}/gallery.json --count 5 --seed 1 --speed 0.29 "
                      "--out people")

#: Commands that read a map file; their help describes the format.
MAP_COMMANDS = {"info", "arcs", "decompose", "analyze", "check", "convert", "sweep", "assess",
                "simulate", "kernel"}
MAP_COMMANDS |= {"tracks"}
MAP_COMMANDS |= {"follow"}

MAP_FORMAT = """\
map files:
  .json     {"name": "room", "boundary": [[x, y], ...], "holes": [[[x, y], ...], ...]}
  .wkt      POLYGON ((x y, ...), (hole ...))
  .geojson  a Polygon, a Feature with a Polygon, or a FeatureCollection of one Feature
  .yaml     a ROS map_server map (its .pgm/.png beside it); free space = largest free component
  Vertices V0.. and edges E0.. follow the file's order (boundary first, then each hole).
  lss must be 0.001 to 1000 times the map's diameter (largest vertex distance).
exit status: 0 ok, 1 check failed, 2 user error (one line), 3 internal error."""


def build_parser() -> argparse.ArgumentParser:
    """The ``tether`` argument parser, every subcommand registered."""
    p = _Parser(
        prog="tether",
        description="Keep a moving target in sight at a fixed distance inside a polygonal map.",
        epilog="run 'tether COMMAND --help' for a command's options and an example; "
               "'tether demo' runs the whole pipeline on the bundled maps.\n"
               "exit status: 0 ok, 1 check failed, 2 user error (one line), "
               "3 internal error (TETHER_DEBUG=1 shows the traceback).",
    )
    p.add_argument("--version", action="version", version=f"tether {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    def add(name: str, fn: Callable, help_: str) -> argparse.ArgumentParser:
        example = EXAMPLES.get(name)
        epilog = f"example:\n  {example}" if example else None
        if name in MAP_COMMANDS:
            epilog = (epilog + "\n\n" if epilog else "") + MAP_FORMAT
        sp = sub.add_parser(name, help=help_, description=help_, epilog=epilog,
                            formatter_class=argparse.RawDescriptionHelpFormatter)
        sp.set_defaults(func=fn)
        return sp

    for group in GROUPS:
        importlib.import_module(f"tether.cli.{group}").register(add)
    return p


def one_line(text: object) -> str:
    """Collapse a message (GEOS and numpy messages may span lines) to a single line."""
    return " ".join(str(text).split()) or "(no message)"


def _debug() -> bool:
    return os.environ.get("TETHER_DEBUG", "") not in ("", "0")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``tether`` command; returns the exit status.

    Exit statuses: 0 success; 1 a check found disagreements; 2 a user error (bad map, bad
    parameter, bad output path, bad arguments), printed as one line ``tether: error: ...``;
    3 an internal error (a bug in tether), printed as one line ``tether: internal error: ...``
    (set ``TETHER_DEBUG=1`` for the traceback). Numerical warnings are never printed.
    """
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: --help/--version (0) or a usage error (2)
        return exc.code if isinstance(exc.code, int) else EXIT_USAGE
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"), \
                memory_limit(getattr(args, "memory_limit", None)):
            if not _debug():
                warnings.simplefilter("ignore")
            return int(args.func(args) or 0)
    except TetherError as exc:
        _say(f"tether: error: {one_line(exc)}")
        return EXIT_USAGE
    except BrokenPipeError:
        _silence_stdout()
        return 0
    except KeyboardInterrupt:
        _say("tether: interrupted")
        return 130
    except RecursionError:
        if _debug():
            traceback.print_exc()
        _say("tether: error: input too deeply nested or too complex")
        return EXIT_USAGE
    except MemoryError:
        _say("tether: error: out of memory: the input or the parameters ask for too much")
        return EXIT_USAGE
    except Exception as exc:  # noqa: BLE001 - the last line of defence: never a traceback
        if _debug():
            traceback.print_exc()
        _say(f"tether: internal error: {type(exc).__name__}: {one_line(exc)} "
             "(please report it; TETHER_DEBUG=1 shows the traceback)")
        return EXIT_INTERNAL


def _say(line: str) -> None:
    try:
        print(line, file=sys.stderr)
    except (OSError, ValueError):
        pass


def _silence_stdout() -> None:
    """After a broken pipe, point stdout at devnull so the interpreter's final flush is quiet."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):
        pass
