"""The deprecated modules ``tether.escape``, ``tether.graph`` and ``tether.assess`` (one
release): importing them warns, and they re-export the very objects of :mod:`tether.analysis`."""

import importlib
import sys

import pytest

import tether.analysis.assessment
import tether.analysis.connectivity
import tether.analysis.elimination
import tether.analysis.escape_points


def _import_fresh(name):
    sys.modules.pop(name, None)
    with pytest.warns(DeprecationWarning, match=name):
        return importlib.import_module(name)


@pytest.mark.parametrize("old, new", [
    ("tether.escape", [tether.analysis.elimination]),
    ("tether.graph", [tether.analysis.connectivity]),
    ("tether.assess", [tether.analysis.assessment, tether.analysis.escape_points]),
])
def test_shim_warns_and_reexports(old, new):
    shim = _import_fresh(old)
    assert shim.__all__
    for name in shim.__all__:
        if name == "TWO_PI":
            continue
        home = next(m for m in new if hasattr(m, name))
        assert getattr(shim, name) is getattr(home, name), name
