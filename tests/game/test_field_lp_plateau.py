"""The search's plateau rule (``tether.game.field_lp``, :data:`PLATEAU_ROUNDS`): a try whose
elastic slack stops falling is stuck even while its ends keep moving (a search that cycles
between two fields never stalls), releases core vertices near the slack, and stops when none
is left. Checked against the rule recomputed from the rounds' own slacks, on the 10 x 10 room
at a coarse mesh (h 1, 0.6), where the slack stays positive."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import corner_room_first_field, lp_rounds

from tether.game.field_lp import PLATEAU_REL, lp_field

VT = 0.6


@pytest.fixture(scope="module")
def room():
    return corner_room_first_field(VT)


def test_a_plateau_releases_then_stops_and_the_rule_holds(room):
    space, lss, f = room
    k = 3
    r = lp_field(space, f.points, f.tri, f.lo, f.w, lss, VT, 1.0, rounds=40, plateau=k)
    rec = lp_rounds(r.log)
    # recompute the rule from the recorded slacks
    best, since = np.inf, 0
    for e in rec:
        if e["slack"] < (1 - PLATEAU_REL) * best:
            best, since = e["slack"], e["round"]
        stuck_here = e["slack"] > 0 and e["round"] - since >= k
        assert (e.get("stuck") == "plateau") == (stuck_here and e.get("stuck") != "stall")
        if "released" in e:
            best, since = np.inf, e["round"]
    plateaus = [e for e in rec if e.get("stuck") == "plateau"]
    assert plateaus and "released" in plateaus[0]  # the first plateau frees core vertices
    assert rec[-1].get("stuck") and "released" not in rec[-1]  # the last one ends the try
    assert r.rounds == rec[-1]["round"] < 40
    assert (r.core <= (f.w >= 2 * np.pi - 1e-9)).all()  # the core only shrinks


@pytest.mark.slow
def test_without_the_plateau_rule_the_try_runs_on(room):
    space, lss, f = room
    r = lp_field(space, f.points, f.tri, f.lo, f.w, lss, VT, 1.0, rounds=7, plateau=0)
    assert r.rounds == 7  # with the rule (k = 3) round 6 is a plateau
    assert not [e for e in lp_rounds(r.log) if e.get("stuck") == "plateau"]
