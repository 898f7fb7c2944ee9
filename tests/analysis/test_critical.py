"""Critical rod lengths of a map (:mod:`tether.analysis.critical`): the distance events, and
the verdicts :func:`tether.analysis.analyze` reports on both sides of one (issue 21)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from lattice_maps import corridor, env_of

from tether.analysis import analyze
from tether.analysis.critical import distance_events, near_critical
from tether.decomposition import decompose
from tether.decomposition.scan import scan
from tether.environment import Environment


def _square(side: float) -> Environment:
    return Environment(np.array([[0.0, 0.0], [side, 0.0], [side, side], [0.0, side]]),
                       name=f"square{side:g}")


def _clean(dec, lines: int = 12) -> None:
    _, bad = scan(dec, lines)
    assert bad == (), bad[:3]


def test_distance_events_of_a_square():
    """The 4 x 4 room: sides 4 apart (events at 4 and 2), diagonals 4·sqrt(2)."""
    ev = distance_events(_square(4.0), 4.0)
    values = sorted({round(e.value, 12) for e in ev})
    assert values == [2.0, round(2 * math.sqrt(2), 12), 4.0]
    assert {(e.a, e.b) for e in ev if e.value == 2.0} == {("V0", "V1"), ("V1", "V2"),
                                                          ("V2", "V3"), ("V0", "V3")}


@pytest.mark.slow
def test_critical_lss_reported_with_the_verdicts_on_both_sides():
    """A 4 x 4 room at lss 2: opposite walls exactly 2·lss apart. Below, a strategy exists;
    above, none (the rod no longer fits across): the two sides are decomposed independently
    here and must match what analyze reports."""
    env = _square(4.0)
    v = analyze(decompose(env, 2.0))
    c = v.critical
    assert c is not None and c.events and not c.same_verdict
    for side, lss in ((c.below, c.value - c.delta), (c.above, c.value + c.delta)):
        ref = analyze(decompose(env, lss), near_critical=False)
        assert side["lss"] == lss
        assert side["strategy_exists"] == ref.strategy_exists
        assert side["counts"] == ref.counts()
    assert c.below["strategy_exists"] and not c.above["strategy_exists"]
    d = v.to_dict()["critical_lss"]
    assert d["delta"] == c.delta and d["events"][0]["multiple"] in (1, 2)


def test_no_critical_report_away_from_critical_lengths():
    env = _square(4.0)
    assert near_critical(env, 1.9)[0] == ()
    assert analyze(decompose(env, 1.9)).critical is None
    assert analyze(decompose(env, 2.0 + 1e-3)).critical is None


def test_corridor_exactly_two_lss_wide_is_critical_and_exact():
    env = env_of(corridor(0.5), "corridor")
    events, value, delta = near_critical(env, 0.5)
    assert any(e.multiple == 2 for e in events) and delta > 0 and value == 0.5
    _clean(decompose(env, 0.5))


@pytest.mark.slow
def test_lss_within_resolution_of_a_critical_length_reports_its_side():
    """0.5 + 1e-7 in a corridor exactly 1 wide: the offsets of its two walls lie 2e-7 apart,
    below resolution. analyze says which side of the critical length 0.5 lss is on, and the
    verdicts on both sides are computed where everything is resolved (and verified)."""
    env = env_of(corridor(0.5), "corridor")
    v = analyze(decompose(env, 0.5 + 1e-7))
    c = v.critical
    assert c is not None and c.value == 0.5 and c.side == "above"
    assert c.below["verified"] and c.above["verified"]
    assert c.to_dict()["side"] == "above"
    on = analyze(decompose(env, 0.5)).critical
    assert on is not None and on.side == "on" and on.value == 0.5
