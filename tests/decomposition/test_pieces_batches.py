"""The pieces' crossings chosen in batches of chains (tether/decomposition/pieces.py
``make_pieces``, ``PIECE_BATCH``; issue 25): with tiny batches (a few chains, many batches)
the pieces and the arcs at their crossings are those of one batch (the same regions,
curves, offsets, verdicts and arcs' features; the samples, normals and angles to within
:data:`_NEAR`: the exact curves' projection, :func:`tether.curves.project_many`, stops its
Gauss-Newton steps once every row of a call has converged, so a row's last bits depend on
the rows projected with it, in one batch as in the chains' order before); the arcs
are the exact free arcs at the crossings' two sides (computed here for all pieces at once);
and a tiled decomposition with tiny batches equals the untiled one up to renumbering."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import GENERIC, SerialExecutor
from renumbering import assert_equal_up_to_renumbering

from tether.arcs import free_arcs_many
from tether.decomposition import decompose, pipeline
from tether.decomposition import pieces as pieces_mod
from tether.decomposition.structure import crossing_points
from tether.examples.floorplan import floor_plan


def _inputs(monkeypatch, env, lss):
    """The arguments ``decompose(env, lss)`` gives ``make_pieces``."""
    got = []
    made = pieces_mod.make_pieces

    def spy(*args):
        got.append(args)
        return made(*args)

    with monkeypatch.context() as mp:
        mp.setattr(pipeline, "make_pieces", spy)
        decompose(env, lss)
    return got[0]


#: How far a sample, normal or arc end may move with the rows projected with it (map units,
#: radians): Gauss-Newton steps past convergence (measured: 1.3e-15 and 1.0e-9 at most).
_NEAR = 1e-8


def assert_same_arcs(a, b):
    for f in ("point", "start_code", "end_code", "full"):
        assert np.array_equal(getattr(a, f), getattr(b, f)), f
    for f in ("start", "end"):
        assert np.allclose(getattr(a, f), getattr(b, f), rtol=0, atol=_NEAR), f


@pytest.mark.slow
def test_tiny_batches_same_pieces_and_exact_arcs(monkeypatch):
    env, lss = GENERIC.internal, 2.5 * GENERIC.frame.scale
    args = _inputs(monkeypatch, env, lss)
    one, _, one_arcs = pieces_mod.make_pieces(*args)
    assert len(one) > 20
    for size in (1, 7):  # a batch of one chain, and batches ending anywhere
        monkeypatch.setattr(pieces_mod, "PIECE_BATCH", size)
        tiny, dropped, arcs = pieces_mod.make_pieces(*args)
        for f in ("pair", "eps", "ok", "desc"):
            assert np.array_equal(getattr(tiny, f), getattr(one, f)), f
        for f in ("q", "n"):
            assert np.allclose(getattr(tiny, f), getattr(one, f), rtol=0, atol=_NEAR), f
        assert tiny.descs == one.descs and dropped == len(args[3]) - len(one)
        assert_same_arcs(arcs, one_arcs)
        # the arcs at both sides of every crossing, as free_arcs_many gives them there
        ref = free_arcs_many(env, crossing_points(tiny.q, tiny.n, tiny.eps), lss, check=False)
        assert_same_arcs(ref, arcs)


@pytest.mark.slow
def test_tiled_with_tiny_batches_equals_untiled(monkeypatch):
    env = floor_plan(40, seed=0)
    lss = (env.bounds[2] - env.bounds[0]) / 15
    whole = decompose(env, lss)
    monkeypatch.setattr(pieces_mod, "PIECE_BATCH", 5)
    tiled = decompose(env, lss, tiles=(3, 3), executor=SerialExecutor())
    assert_equal_up_to_renumbering(whole, tiled)
