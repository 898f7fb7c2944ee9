"""The registries of controllers and target kinds (:mod:`tether.strategies`), and their old
names in :mod:`tether.sim`, deprecated for one release."""

import subprocess
import sys

import pytest

import tether.sim.controller
import tether.sim.targets
from tether.errors import InvalidParameterError
from tether.strategies import CONTROLLERS, TARGETS, make_target


def test_registries_name_the_players_of_sim_and_game():
    assert list(CONTROLLERS) == ["paper", "follow", "translate", "kernel", "certified"]
    assert list(TARGETS) == ["path", "random", "wall", "tangential", "dash", "escape",
                             "search", "kernel-evader", "track", "pedestrian"]
    with pytest.raises(InvalidParameterError, match="unknown target kind 'nope'"):
        make_target("nope", None)


@pytest.mark.slow
def test_sim_never_imports_the_game():
    code = ("import sys, tether.sim.controller, tether.sim.targets, tether.sim.simulate, "
            "tether.sim.scenarios, tether.sim.diagnose; "
            "print(sorted(m for m in sys.modules if m.startswith(('tether.game', "
            "'tether.strategies'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "[]"


@pytest.mark.parametrize("module, name, new", [
    (tether.sim.controller, "CONTROLLERS", CONTROLLERS),
    (tether.sim.targets, "TARGETS", TARGETS),
    (tether.sim.targets, "make_target", make_target),
])
def test_old_registry_names_warn_and_forward(module, name, new):
    with pytest.warns(DeprecationWarning, match=f"tether.strategies.{name}"):
        assert getattr(module, name) is new
    with pytest.raises(AttributeError):
        module.NOT_A_NAME  # noqa: B018
