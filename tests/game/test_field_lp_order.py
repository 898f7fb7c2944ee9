"""``solve_field`` runs the first LP round of every core size, then finishes the tries in the
order of that round's slack (least first); a try finished after its probe must be the same
search as one run alone. Checked on the 10 x 10 room's coarse mesh (h 1) against
``lp_field`` run separately for each core size (its first round, and its whole search)."""

from __future__ import annotations

import numpy as np
import pytest

from tether.examples import path as example_path
from tether.game import surveillance_kernel
from tether.game.certificate import ArcField, certify, first_field
from tether.game.field_lp import CORE_TRIES, initial_core, lp_field, solve_field, vortex_radius
from tether.io import load_map

ROUNDS = 6


@pytest.fixture(scope="module", params=[0.3, pytest.param(0.6, marks=pytest.mark.slow)])
def game(request):
    vt = request.param
    env = load_map(example_path("nonconvex_corner"))
    space, s = env.internal, env.frame.scale
    kern = surveillance_kernel(space, s, vt, 1.0, h=1.0 * s, orientations=90)
    return space, s, vt, kern, first_field(kern)


def test_tries_run_in_the_order_of_their_first_slack(game):
    space, lss, vt, kern, f = game
    r_v = vortex_radius(lss, vt, 1.0)
    alone = {}
    for q in CORE_TRIES:
        core = initial_core(f.points, f.w, q * r_v)
        if any(np.array_equal(core, c) for c, _ in alone.values()):
            continue  # the same core: the same search, skipped
        one = lp_field(space, f.points, f.tri, f.lo, f.w, lss, vt, 1.0, rounds=1,
                       core_radius=q * r_v)
        alone[q] = (core, one.slack)
    _, _, log = solve_field(space, kern, lss, vt, 1.0, rounds=ROUNDS)
    tries = [e for e in log if "core" in e]
    if len(alone) == 1:
        assert [e["core"] for e in tries] == list(alone)
        return
    want = sorted(alone, key=lambda q: (alone[q][1], CORE_TRIES.index(q)))
    ran = [e["core"] for e in tries]
    assert ran == want[:len(ran)]
    for e in tries:
        assert e["first_slack"] == pytest.approx(alone[e["core"]][1], rel=1e-9, abs=1e-9)
    assert len(ran) == len(want) or tries[-1]["failing"] == 0


def test_a_try_finished_after_the_probes_is_the_search_alone(game):
    """Every try is the search ``lp_field`` gives alone with its core size, whether it went
    on from its first round (the least first slack) or started again after its model was
    dropped (the other tries' first rounds share nothing with it): the same width and the
    same failing triangles, and the kept field is that search's, bit for bit; ``certify``
    agrees with the verdicts recorded."""
    space, lss, vt, kern, f = game
    g, checks, log = solve_field(space, kern, lss, vt, 1.0, rounds=ROUNDS)
    r_v = vortex_radius(lss, vt, 1.0)
    for e in (e for e in log if "core" in e):
        r = lp_field(space, f.points, f.tri, f.lo, f.w, lss, vt, 1.0, rounds=ROUNDS,
                     core_radius=e["core"] * r_v)
        alone = ArcField(f.points, f.tri, r.lo, np.minimum(r.hi - r.lo, 2 * np.pi))
        assert e["mean_w"] == float(np.mean(alone.w) / (2 * np.pi))
        assert e["failing"] == int(certify(alone, space, lss, vt, 1.0).bad.sum())
        if e.get("kept"):
            assert np.array_equal(g.lo, alone.lo) and np.array_equal(g.w, alone.w)
    kept = next(e for e in log if e.get("kept"))
    again = certify(g, space, lss, vt, 1.0)
    assert int(again.bad.sum()) == int(checks.bad.sum()) == kept["failing"]


@pytest.mark.slow
@pytest.mark.parametrize("vt", [0.3, 0.6])
def test_settled_rounds_end_the_wait_with_the_same_verdict(monkeypatch, vt):
    """``SETTLED`` ends a plateau's wait at a round that adds no cutting plane and does not
    improve: on the 10 x 10 room at ``h`` 0.5 the search with it gives the same verdict and
    width (within 0.5 %) as the search that waits out the plateau rounds, in no more
    rounds."""
    import tether.game.field_lp as field_lp

    env = load_map(example_path("nonconvex_corner"))
    space, s = env.internal, env.frame.scale
    kern = surveillance_kernel(space, s, vt, 1.0, h=0.5 * s, orientations=90)
    runs = {}
    for settled in (True, False):
        monkeypatch.setattr(field_lp, "SETTLED", settled)
        g, checks, log = solve_field(space, kern, s, vt, 1.0)
        tries = [e for e in log if "core" in e]
        runs[settled] = (checks.passed, float(np.mean(g.w)), sum(e["rounds"] for e in tries),
                         [e["stuck"] for e in tries])
    assert runs[True][0] == runs[False][0]
    assert runs[True][1] == pytest.approx(runs[False][1], rel=5e-3)
    assert runs[True][2] <= runs[False][2]
    assert any(st == "settled" for t in runs[True][3] for _, st in t)  # the rule acted
