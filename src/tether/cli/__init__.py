"""The ``tether`` command. Thin: parses arguments, calls the library, prints.

Every user error (bad map, bad parameter, target outside the free space) is printed as one line
``tether: error: ...`` on stderr with exit status 2; no traceback.

Each command group lives in its own module of this package and exposes ``register(add)``;
a new group is one line in :data:`GROUPS`.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Callable, Sequence

from tether.cli.common import example_path
from tether.errors import TetherError

__all__ = ["GROUPS", "build_parser", "example_path", "main"]

EXIT_USAGE = 2

#: Modules of :mod:`tether.cli` that add subcommands, in the order of ``tether --help``.
GROUPS = [
    "maps",
    "motion",
    "ros",
]


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="tether",
        description="Keep a moving target in sight at a fixed distance inside a polygonal map.",
    )
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    def add(name: str, fn: Callable, help_: str) -> argparse.ArgumentParser:
        sp = sub.add_parser(name, help=help_, description=help_)
        sp.set_defaults(func=fn)
        return sp

    for group in GROUPS:
        importlib.import_module(f"tether.cli.{group}").register(add)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``tether`` command; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except TetherError as exc:
        print(f"tether: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except BrokenPipeError:
        return 0
