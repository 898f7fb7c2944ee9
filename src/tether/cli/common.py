"""Helpers shared by the command groups: bundled examples, JSON output, argument types."""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable

from tether.errors import NonFiniteResultError
from tether.examples import path as example_path  # noqa: F401 (tether.cli.example_path)

__all__ = [
    "LSS_HELP", "MAP_HELP", "add_map_lss", "add_speeds", "check_plot_arg", "deg", "finite_arg",
    "float_arg", "float_range", "int_range", "load_map_lss", "print_json",
    "MEMORY_LIMIT_HELP", "add_memory_limit", "size_arg", "dask_executor",
]


def print_json(obj: object) -> None:
    """Print ``obj`` as strict JSON (no NaN or Infinity), whole or not at all.

    Raises
    ------
    NonFiniteResultError
        If a value is not finite; the message names its field (``arcs[0].end``).
    """
    try:
        text = json.dumps(obj, indent=1, allow_nan=False)
    except ValueError:
        where = _non_finite_path(obj, "") or "a value"
        raise NonFiniteResultError(f"result {where} is not a finite number; the input is "
                                   "beyond tether's numerical range") from None
    sys.stdout.write(text + "\n")


def _non_finite_path(obj: object, path: str) -> str | None:
    """Path of the first non-finite float in nested dicts/lists (``rounds[2].time``)."""
    if isinstance(obj, float):
        return None if math.isfinite(obj) else (path or "value")
    if isinstance(obj, dict):
        for k, v in obj.items():
            found = _non_finite_path(v, f"{path}.{k}" if path else str(k))
            if found:
                return found
    elif isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj):
            found = _non_finite_path(v, f"{path}[{i}]")
            if found:
                return found
    return None


def deg(a: float) -> str:
    """An angle in radians shown in degrees, 7 characters wide."""
    return f"{math.degrees(a):7.2f}°"


def float_arg(text: str) -> float:
    """Argparse type: a float (the library rejects non-finite values with a named message)."""
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None


def finite_arg(text: str) -> float:
    """Argparse type: a finite float (``nan``, ``inf`` and overflowing literals rejected)."""
    val = float_arg(text)
    if not math.isfinite(val):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return val


def float_range(lo: float | None = None, hi: float | None = None, *,
                lo_open: bool = False) -> Callable[[str], float]:
    """Argparse type: a finite float in ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``)."""

    def parse(text: str) -> float:
        val = finite_arg(text)
        low_bad = lo is not None and (val <= lo if lo_open else val < lo)
        if low_bad or (hi is not None and val > hi):
            left = "(" if lo_open else "["
            raise argparse.ArgumentTypeError(
                f"{text!r} is out of range {left}{'-inf' if lo is None else f'{lo:g}'}, "
                f"{'inf' if hi is None else f'{hi:g}'}]")
        return val

    parse.__name__ = "number"
    return parse


def int_range(lo: int | None = None, hi: int | None = None) -> Callable[[str], int]:
    """Argparse type: an integer in ``[lo, hi]`` (at most 20 digits)."""

    def parse(text: str) -> int:
        t = text.strip()
        if len(t) > 20:
            raise argparse.ArgumentTypeError(f"not an integer of at most 20 digits: "
                                             f"{text[:24]!r}...")
        try:
            val = int(t)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
        if (lo is not None and val < lo) or (hi is not None and val > hi):
            raise argparse.ArgumentTypeError(
                f"{val} is out of range [{'-inf' if lo is None else lo}, "
                f"{'inf' if hi is None else hi}]")
        return val

    parse.__name__ = "integer"
    return parse


MAP_HELP = "map file (.json, .geojson, .wkt or ROS .yaml)"
LSS_HELP = ("rod length (map units), between 0.001 and 1000 times the map's diameter "
            "(the largest distance between two of its vertices)")


def add_map_lss(sp: argparse.ArgumentParser) -> None:
    """Add the MAP argument and ``--lss`` (map units) to a command (and
    ``--memory-limit``: every such command decomposes the map)."""
    sp.add_argument("map", help=MAP_HELP)
    sp.add_argument("--lss", type=float_arg, required=True, help=LSS_HELP)
    add_memory_limit(sp)


MEMORY_LIMIT_HELP = ("memory the decomposition may use, e.g. 8G or 500M (K, M, G, T: powers "
                     "of 1024; default: TETHER_MEMORY_LIMIT, else what this machine lets the "
                     "process use); a decomposition estimated above it is refused at once")


def size_arg(text: str) -> int:
    """Argparse type: a memory size in bytes (:func:`tether._util.memory.parse_size`)."""
    from tether._util.memory import parse_size
    from tether.errors import InvalidParameterError

    try:
        return parse_size(text)
    except InvalidParameterError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_memory_limit(sp: argparse.ArgumentParser) -> None:
    """Add ``--memory-limit SIZE`` (applied by :func:`tether.cli.main` around the command)."""
    sp.add_argument("--memory-limit", type=size_arg, metavar="SIZE", help=MEMORY_LIMIT_HELP)


def load_map_lss(args: argparse.Namespace):
    """Load ``args.map`` and check ``args.lss`` against its diameter; return the map."""
    from tether.arcs import check_lss
    from tether.io import load_map

    env = load_map(args.map)
    check_lss(args.lss, env)
    return env


def add_speeds(sp: argparse.ArgumentParser, required: bool) -> None:
    """Add ``--vt`` and ``--vo`` (map units per second) to a command."""
    kw = {"required": True} if required else {}
    sp.add_argument("--vt", type=float_arg, help="target speed bound", **kw,
                    **({} if required else {"default": 1.0}))
    sp.add_argument("--vo", type=float_arg, help="observer speed bound (> vt)", **kw,
                    **({} if required else {"default": 2.0}))
    sp.add_argument("--lss", type=float_arg, help="rod length (map units)", **kw,
                    **({} if required else {"default": 1.0}))


def check_plot_arg(args: argparse.Namespace, attr: str = "plot") -> None:
    """Validate an optional image output argument (``--plot``) before any computation."""
    from tether._util.files import IMAGE_KINDS, check_output_path

    value = getattr(args, attr, None)
    if value is not None:
        check_output_path(value, IMAGE_KINDS)


def dask_executor(address: str, timeout: float) -> tuple[object, Callable[[], None]]:
    """The executor of the Dask cluster at ``address`` and a function that closes the client.

    Raises
    ------
    TetherError
        Without the ``cluster`` extra, or when the scheduler cannot be reached in ``timeout``
        seconds (one line).
    """
    from tether.errors import TetherError

    try:
        from distributed import Client
    except ImportError:
        raise TetherError("--dask needs the cluster extra: pip install 'tether[cluster]'") \
            from None
    try:
        client = Client(address, timeout=timeout)
    except (OSError, TimeoutError) as exc:
        raise TetherError(f"cannot reach the Dask scheduler at {address!r} ({exc})") from None
    return client.get_executor(), client.close
