"""The bundled examples: their paths, names and maps, and the floor-plan generator's old name."""

from __future__ import annotations

import importlib
import sys

import pytest

from tether import examples
from tether.cli import example_path
from tether.examples.floorplan import floor_plan


def test_names_paths_and_maps():
    assert examples.names() == ["convex_corner", "gallery", "nonconvex_corner", "rectangle"]
    for name in examples.names():
        assert examples.path(name).is_file()
        assert examples.load(name).name == name
    assert examples.path("office", ".yaml").is_file()
    assert examples.load("office", ".yaml").n > 0
    assert example_path is examples.path  # the command line's name


def test_floorplan_is_a_deprecated_alias():
    sys.modules.pop("tether.floorplan", None)
    with pytest.warns(DeprecationWarning, match="tether.examples.floorplan"):
        old = importlib.import_module("tether.floorplan")
    assert old.floor_plan is floor_plan is examples.floor_plan
