"""The bundled example maps (package data: ``gallery``, ``rectangle``, ``convex_corner``,
``nonconvex_corner`` as ``.json``, ``.geojson`` and ``.wkt``; the ROS map ``office`` as
``.yaml`` + ``.pgm``) and a seeded floor-plan generator (:mod:`tether.examples.floorplan`)."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from tether.environment import Environment
from tether.examples.floorplan import floor_plan
from tether.io import load_map

__all__ = ["floor_plan", "load", "names", "path"]


def path(name: str, suffix: str = ".json") -> Path:
    """Path of a bundled example map (``rectangle``, ``gallery``, ...) in the format of
    ``suffix`` (``.json``, ``.geojson``, ``.wkt``; ``.yaml`` for ``office``)."""
    return Path(str(resources.files("tether") / "examples" / f"{name}{suffix}"))


def load(name: str, suffix: str = ".json") -> Environment:
    """A bundled example map, read by :func:`tether.io.load_map` from :func:`path`."""
    return load_map(path(name, suffix))


def names() -> list[str]:
    """The names of the bundled polygon maps (those with a ``.json`` file), sorted."""
    folder = resources.files("tether") / "examples"
    return sorted(Path(p.name).stem for p in folder.iterdir() if p.name.endswith(".json"))
