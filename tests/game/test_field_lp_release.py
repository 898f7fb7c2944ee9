"""The search's release rule (``tether.game.field_lp``, :data:`RELEASE_ROUNDS`,
:data:`RELEASE_REL`): a release of core vertices whose slack has not fallen by a quarter of its
best before the release within three rounds ends the try, if that round still added cutting
planes for over 1 % of the LP's rows. Checked against the rule recomputed
from the rounds' own slacks, on the 10 x 10 room at a coarse mesh (h 1) at vt/vo 0.9, where no
field exists and the release does not pay, and at 0.6, where it does."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import corner_room_first_field, lp_rounds

from tether.game.field_lp import RELEASE_CUTS, RELEASE_REL, RELEASE_ROUNDS, lp_field

PLATEAU = 3  # rounds: a short plateau, so that the release comes early


def _release_checks(rec: list) -> list:
    """Per release in ``rec``: (the round that judges it, whether it paid, whether that round
    still grew the LP), recomputed from the recorded slacks (the best before it: the least
    slack since the try's start or the previous release) and cutting planes."""
    out, start = [], 0
    for i, e in enumerate(rec):
        if "released" in e:
            before = min(x["slack"] for x in rec[start:i + 1])
            after = [x["slack"] for x in rec[i + 1:i + 1 + RELEASE_ROUNDS]]
            if len(after) == RELEASE_ROUNDS:
                ratio = min(after) / before
                # the search's best is within 0.1 % of the least (its plateau threshold)
                assert abs(ratio - (1 - RELEASE_REL)) > 2e-3, "too near the threshold to judge"
                judge = rec[i + RELEASE_ROUNDS]
                out.append((judge["round"], ratio <= 1 - RELEASE_REL,
                            judge["cuts_added"] > RELEASE_CUTS * judge["rows"]))
            start = i + 1
    return out


def test_a_release_that_does_not_pay_ends_the_try():
    space, lss, f = corner_room_first_field(0.9)
    r = lp_field(space, f.points, f.tri, f.lo, f.w, lss, 0.9, 1.0, rounds=40, plateau=PLATEAU)
    rec = lp_rounds(r.log)
    checks = _release_checks(rec)
    assert checks and not checks[-1][1] and checks[-1][2]  # the last release did not pay ...
    assert rec[-1]["round"] == checks[-1][0] == r.rounds < 40  # ... and its judge ended it
    assert rec[-1].get("stuck") == "release"
    for rnd, paid, growing in checks[:-1]:  # any earlier release paid or was settling
        assert (paid or not growing) and rec[rnd - 1].get("stuck") != "release"
    assert r.slack > 0


def test_a_release_that_pays_lets_the_try_go_on():
    space, lss, f = corner_room_first_field(0.6)
    r = lp_field(space, f.points, f.tri, f.lo, f.w, lss, 0.6, 1.0, rounds=40, plateau=PLATEAU)
    rec = lp_rounds(r.log)
    checks = _release_checks(rec)
    assert checks and all(paid for _, paid, _ in checks)
    assert not [e for e in rec if e.get("stuck") == "release"]
    assert r.rounds > checks[0][0]  # the try went on past the first release's judge


@pytest.mark.slow
def test_without_the_release_rule_the_try_runs_on():
    space, lss, f = corner_room_first_field(0.9)
    with_rule = lp_field(space, f.points, f.tri, f.lo, f.w, lss, 0.9, 1.0, rounds=40,
                         plateau=PLATEAU)
    n = with_rule.rounds + 2
    r = lp_field(space, f.points, f.tri, f.lo, f.w, lss, 0.9, 1.0, rounds=n, plateau=PLATEAU,
                 release_rounds=0)
    assert r.rounds == n  # past the round where the rule ends the try
    assert not [e for e in lp_rounds(r.log) if e.get("stuck") == "release"]
    assert np.isfinite(r.slack)
