"""The flat modules the figures lived in before tether.plot became a package: each still
imports, warns that it is deprecated and re-exports its names from the new home."""

import importlib
import sys

import pytest


@pytest.mark.parametrize("old, new, names", [
    ("tether.plot_kernel", "tether.plot.kernel",
     ["SLICE_COLOURS", "plot_safe_fraction", "plot_kernel_slice", "kernel_figure",
      "plot_kernel_run", "kernel_run_strip"]),
    ("tether.plot_sweep", "tether.plot.sweep", ["plot_sweep"]),
    ("tether.animate", "tether.plot.run", ["MODE_COLOURS", "plot_run", "animate_run"]),
])
def test_shim_warns_and_reexports(monkeypatch, old, new, names):
    monkeypatch.delitem(sys.modules, old, raising=False)
    with pytest.warns(DeprecationWarning, match=new.replace(".", r"\.")):
        shim = importlib.import_module(old)
    home = importlib.import_module(new)
    for name in names:
        assert getattr(shim, name) is getattr(home, name)
    assert shim.__all__ == home.__all__


def test_the_package_keeps_the_names_of_the_old_module():
    import tether.plot as plot

    for name in ("TARGET_COLOUR", "OBSERVER_COLOUR", "ROD_COLOUR", "CURVE_COLOURS", "new_axes",
                 "save", "plot_tractrix", "plot_rotation", "plot_wall", "plot_vertex",
                 "plot_distance_bound", "bound_figure", "plot_map", "plot_decomposition",
                 "plot_graph", "plot_verdict"):
        assert name in plot.__all__
    assert all(hasattr(plot, name) for name in plot.__all__)
