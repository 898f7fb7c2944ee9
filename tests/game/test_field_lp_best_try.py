"""``solve_field`` keeps the best try, not the last: the fewest failing triangles, then the
widest (mean width), then the earliest, and marks its record ``"kept"``. The rule is checked
with the search and the checks replaced by scripted ones (which try fails how much is then
known in advance), and on the 10 x 10 room at a coarse mesh (``vt`` 0.6), where the three core
sizes all fail within 3 rounds, against ``certify`` run again on the field returned."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import corner_room_first_field

import tether.game.field_lp as field_lp
from tether.game.certificate import ArcField, Checks, certify
from tether.game.field_lp import CORE_TRIES, LPResult, solve_field

TAU = 2 * np.pi


def _checks(nt: int, failing: int) -> Checks:
    bad = np.zeros(nt, bool)
    bad[:failing] = True
    none = np.zeros(nt, bool)
    return Checks(none, none, bad, none, ~none)


def _scripted(monkeypatch, f: ArcField, failing: list[int], widths: list[float]) -> None:
    """The ``i``-th search (``lp_rounds`` call) returns the constant width ``widths[i + 1]``
    (rad), ``widths[0]`` being a start field's; a field of width ``widths[i]`` fails on
    ``failing[i]`` triangles; the first field is ``f``."""
    nt = len(f.tri)
    by_w = dict(zip(widths, failing, strict=True))
    calls = iter(widths[1:])

    def fake_rounds(env, points, tri, lo, w, lss, vt, vo, **_):
        """A search that ends before its first round (a generator, as ``lp_rounds``), with
        the same slack for every try: the tries then run in the order of ``CORE_TRIES``."""
        lo2 = np.zeros(len(points))
        return LPResult(lo2, lo2 + next(calls), 1.0, 2, [], np.zeros(len(points), bool))
        yield  # pragma: no cover

    monkeypatch.setattr(field_lp, "first_field", lambda kern, grow=0.0: f)
    monkeypatch.setattr(field_lp, "lp_rounds", fake_rounds)
    made = iter(range(1, 100))  # a distinct core per try: none is skipped as a repeat
    monkeypatch.setattr(field_lp, "initial_core",
                        lambda points, w, radius: np.arange(len(points)) < next(made))
    monkeypatch.setattr(field_lp, "certify",
                        lambda g, *a, **k: _checks(nt, by_w[float(g.w[0])]))


@pytest.fixture(scope="module")
def room():
    return corner_room_first_field(0.5)


@pytest.mark.parametrize(("failing", "widths", "kept"), [
    ([5, 2, 7], [1.0, 2.0, 3.0], 1),   # fewest failing, though not the last
    ([4, 4, 9], [1.0, 2.5, 3.0], 1),   # a tie on failing: the wider
    ([3, 6, 3], [2.0, 1.0, 2.0 + 1e-9], 2),  # a tie: the wider, by a hair
    ([0, 1, 1], [1.0, 2.0, 3.0], 0),   # a certified try ends the search
])
def test_the_best_try_is_kept(monkeypatch, room, failing, widths, kept):
    space, lss, f = room
    _scripted(monkeypatch, f, [-1] + failing, [0.0] + widths)
    g, checks, log = solve_field(space, None, lss, 0.5, 1.0)
    tries = [e for e in log if "core" in e]
    assert len(tries) == (1 if failing[0] == 0 else 3)
    assert [e.get("kept", False) for e in tries] == [i == kept for i in range(len(tries))]
    assert np.allclose(g.w, widths[kept]) and int(checks.bad.sum()) == failing[kept]


def test_equal_tries_keep_the_earliest(monkeypatch, room):
    """Tries 1 and 3 are equal (failing and width), try 2 is wider: it is kept; with it
    removed by a tie on width too, the earliest of equals is."""
    space, lss, f = room
    _scripted(monkeypatch, f, [-1, 2, 2, 2], [0.0, 1.0, 1.5, 1.0])
    _, _, log = solve_field(space, None, lss, 0.5, 1.0)
    assert [e.get("kept", False) for e in log] == [False, True, False]
    _scripted(monkeypatch, f, [-1, 2, 2, 2], [0.0, 1.0, 1.0, 1.0])
    _, _, log = solve_field(space, None, lss, 0.5, 1.0)
    assert [e.get("kept", False) for e in log] == [True, False, False]


def test_the_kept_field_is_the_fewest_failing_and_certify_agrees():
    """Real searches (``vt`` 0.6, 3 rounds per core size, none certifies): the field returned
    fails ``certify``, run again here, on exactly the fewest triangles any try recorded."""
    from tether.game import surveillance_kernel

    space, lss, _ = corner_room_first_field(0.6)
    kern = surveillance_kernel(space, lss, 0.6, 1.0, h=1.0 * lss, orientations=90)
    g, checks, log = solve_field(space, kern, lss, 0.6, 1.0, rounds=3)
    tries = [e for e in log if "core" in e]
    assert len(tries) == len(CORE_TRIES)
    again = certify(g, space, lss, 0.6, 1.0)
    assert int(again.bad.sum()) == int(checks.bad.sum()) == min(e["failing"] for e in tries)
    assert sum(e.get("kept", False) for e in tries) == 1
    kept = next(e for e in tries if e.get("kept"))
    assert np.isclose(np.mean(g.w) / TAU, kept["mean_w"])


def test_a_given_start_is_a_try_too(monkeypatch, room):
    """A start field that fails on fewer triangles than every search after it (one from it,
    three from the first field) is kept."""
    space, lss, f = room
    _scripted(monkeypatch, f, [1, 5, 6, 7, 8], [0.5, 1.0, 2.0, 3.0, 4.0])
    start = ArcField(f.points, f.tri, np.zeros(len(f.points)), np.full(len(f.points), 0.5))
    g, checks, log = solve_field(space, None, lss, 0.5, 1.0, start=start)
    assert [e.get("kept", False) for e in log] == [True] + [False] * 4
    assert log[0]["start"] == "given" and np.allclose(g.w, 0.5) and int(checks.bad.sum()) == 1
