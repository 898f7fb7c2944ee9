"""The end rows of the base headings go only to *steep* triangles (``BASE_STEEP``): those
one of whose ends has a gradient ``G`` with ``lss·vt·|G|`` at least the least end bound any
heading can have (less half the margin); a gentler end violates no heading. Checked against
the bound sampled densely here (not ``window_floor``), round by round, and the search with
the rule against the search with every base row from the start (``base_steep`` 0) on the
10 x 10 room: the same verdict of ``certify`` and the same width within 0.5 %."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import corner_room_first_field

import tether.game.field_lp as field_lp
from tether.examples import path as example_path
from tether.game import surveillance_kernel
from tether.game.certificate import hat_gradients, lifted_ends
from tether.game.field_lp import solve_field
from tether.io import load_map

MARGIN = 0.03  # lp_rounds' default margin


def _f_min(vt: float, sgn: float) -> float:
    """The least end bound over every orientation offset, sampled densely (map units/s)."""
    x = np.linspace(0, math.tau, 400_001)
    return float((np.sqrt(1 - (vt * np.cos(x)) ** 2) + sgn * vt * np.sin(x)).min())


@pytest.mark.parametrize("vt", [0.3, 0.6])
def test_base_rows_go_to_the_steep_triangles_only(monkeypatch, vt):
    """Each round's model holds the base headings' rows of every triangle that was steep at
    a field the search has seen (the reference, or a round's solution), and of no triangle
    gentle at all of them; the steep triangles are judged here against the sampled bound
    (a triangle within the floor's Lipschitz term of the line may go either way)."""
    space, lss, f = corner_room_first_field(vt)
    tri, hat = f.tri, hat_gradients(f.points[f.tri])
    k = lss * vt
    line = {sgn: _f_min(vt, sgn) - MARGIN / 2 for sgn in (-1.0, 1.0)}
    tol = 1e-3  # the floor's Lipschitz term at 4096 samples is below 5e-4 (units of line)
    fields = [(f.lo.copy(), f.w.copy())]  # every field the search looked at, in order
    seen = []  # per round: the model's rows, and how many fields had been seen then
    orig_solve = field_lp._RoundLP.solve

    def solve(self, *a):
        seen.append((self.have.copy(), len(fields)))
        return orig_solve(self, *a)

    monkeypatch.setattr(field_lp._RoundLP, "solve", solve)
    monkeypatch.setattr(field_lp, "lifted_ends",
                        lambda lo, w, t: fields.append((lo.copy(), w.copy()))
                        or lifted_ends(lo, w, t))
    # no core: every triangle is end-checked in every round (no release changes that)
    field_lp.lp_field(space, f.points, tri, f.lo, f.w, lss, vt, 1.0, rounds=5,
                      core=np.zeros(len(f.points), bool))
    assert len(seen) >= 2
    step = seen[0][0].shape[1] // field_lp.BASE_HEADINGS

    def ratio(lo, w):  # per triangle: the larger of k·|G| / line over both ends
        Lt, Ht, _ = lifted_ends(lo, w, tri)
        out = np.zeros(len(tri))
        for sgn, Z in ((-1.0, Lt), (1.0, Ht)):
            G = np.einsum("nvk,nv->nk", hat, Z)
            out = np.maximum(out, k * np.hypot(G[:, 0], G[:, 1]) / line[sgn])
        return out

    ratios = [ratio(lo, w) for lo, w in fields]
    for rows, n in seen:
        worst = np.max(ratios[:n], axis=0)
        have = rows[:, ::step].all(axis=(1, 2))
        assert (have | ~rows[:, ::step].any(axis=(1, 2))).all()  # all base rows, or none
        assert not ((worst > 1 + tol) & ~have).any()  # no steep triangle lacks them
        assert not ((worst < 1 - tol) & have).any()  # no gentle one has them
    assert (ratios[0] > 1 + tol).any() and (ratios[0] < 1 - tol).any()  # both kinds occur
    for (a, _), (b, _) in zip(seen, seen[1:], strict=False):
        assert not (a & ~b).any()  # rows are kept from then on


@pytest.mark.slow
@pytest.mark.parametrize("vt", [0.3, 0.6])
def test_steep_rows_give_the_verdict_of_every_row(monkeypatch, vt):
    """On the 10 x 10 room at ``h`` 0.5 the search with the steep rule and with every base
    row from the start give the same verdict of ``certify`` and widths within 0.5 %, the
    rule's LP with fewer rows."""
    env = load_map(example_path("nonconvex_corner"))
    space, s = env.internal, env.frame.scale
    kern = surveillance_kernel(space, s, vt, 1.0, h=0.5 * s, orientations=90)
    runs = {}
    orig = field_lp.lp_rounds
    for steep in (field_lp.BASE_STEEP, 0.0):
        monkeypatch.setattr(field_lp, "lp_rounds",
                            lambda *a, _b=steep, **kw: orig(*a, base_steep=_b, **kw))
        rows = []
        g, checks, log = solve_field(space, kern, s, vt, 1.0,
                                     progress=lambda e, rows=rows: rows.append(e["rows"]))
        runs[steep] = (checks.passed, float(np.mean(g.w)), int(checks.bad.sum()), rows[0])
    assert field_lp.BASE_STEEP > 0
    assert runs[field_lp.BASE_STEEP][0] == runs[0.0][0] is True  # both certified
    assert runs[field_lp.BASE_STEEP][2] == runs[0.0][2]
    assert runs[field_lp.BASE_STEEP][1] == pytest.approx(runs[0.0][1], rel=5e-3)
    assert runs[field_lp.BASE_STEEP][3] < runs[0.0][3]  # the first LP has fewer rows
