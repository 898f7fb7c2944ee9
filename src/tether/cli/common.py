"""Helpers shared by the command groups: bundled examples, JSON output, argument types."""

from __future__ import annotations

import argparse
import json
import math
import sys
from importlib import resources
from pathlib import Path


def example_path(name: str) -> Path:
    """Path of a bundled example map (``rectangle``, ``gallery``, ...)."""
    return Path(str(resources.files("tether") / "examples" / f"{name}.json"))


def print_json(obj: object) -> None:
    json.dump(obj, sys.stdout, indent=1, allow_nan=False)
    sys.stdout.write("\n")


def deg(a: float) -> str:
    return f"{math.degrees(a):7.2f}°"


def float_arg(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None


def add_map_lss(sp: argparse.ArgumentParser) -> None:
    sp.add_argument("map", help="map file (.json, .geojson or .wkt)")
    sp.add_argument("--lss", type=float_arg, required=True, help="rod length (map units)")


def add_speeds(sp: argparse.ArgumentParser, required: bool) -> None:
    kw = {"required": True} if required else {}
    sp.add_argument("--vt", type=float_arg, help="target speed bound", **kw,
                    **({} if required else {"default": 1.0}))
    sp.add_argument("--vo", type=float_arg, help="observer speed bound (> vt)", **kw,
                    **({} if required else {"default": 2.0}))
    sp.add_argument("--lss", type=float_arg, help="rod length (map units)", **kw,
                    **({} if required else {"default": 1.0}))


def check_plot_arg(args: argparse.Namespace, attr: str = "plot") -> None:
    """Validate an optional image output argument (``--plot``) before any computation."""
    from tether.output import IMAGE_KINDS, check_output_path

    value = getattr(args, attr, None)
    if value is not None:
        check_output_path(value, IMAGE_KINDS)
