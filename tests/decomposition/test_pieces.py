"""Pieces held as columns, against the per-piece objects they replaced.

The reference is the former piece construction of ``_make_pieces`` (one :class:`Piece` per
chain with a crossing, its curves described through a dict of tuples) and the former
``UserFrame.pieces`` (each piece's sample, offset and features rewritten in the user's frame),
kept here. The lazy sequence ``dec.pieces``, the crossings, the unverified pieces and the
region pairs G reads must equal what the objects gave.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest
import shapely
from conftest import GENERIC, SQUARE_HOLE

from tether import Environment
from tether.analysis.connectivity import piece_regions
from tether.decomposition import FREE, Piece, decompose, pipeline, verify
from tether.decomposition import pieces as pieces_mod
from tether.decomposition.pieces import _describe_chains
from tether.examples.floorplan import floor_plan


def _reference_pieces(env, arr, regions, chains, cands, curves, lss) -> list[Piece]:
    """The former construction: one Piece object per kept chain, internal frame."""
    sptr, ssrc = arr.chain_sources(chains)
    got, _ = pieces_mod._pick_crossings(env, chains, cands, regions, curves, (sptr, ssrc), lss)
    kept = np.flatnonzero(cands.count > 0)
    geoms = pieces_mod._chain_geometries(arr, chains, kept).tolist()
    flat, ptr = ssrc.tolist(), sptr.tolist()
    pieces = []
    for k, i in enumerate(kept.tolist()):
        key = tuple(flat[ptr[i]:ptr[i + 1]])
        kinds = "".join(sorted({curves[c].kind for c in key})) or "?"
        feats = tuple(dict.fromkeys(f for c in key for f in curves[c].features))
        q, n = got["q"][i].tolist(), got["n"][i].tolist()
        pieces.append(Piece(k, (int(chains.pair[i, 0]), int(chains.pair[i, 1])), key, kinds,
                            feats, geoms[k], (q[0], q[1]), (n[0], n[1]),
                            float(got["eps"][i]), bool(got["ok"][i])))
    return pieces


def _reference_user(pieces: list[Piece], env: Environment) -> list[tuple]:
    """The former ``UserFrame.pieces``: every piece's public fields in the map's frame (the
    line as WKB)."""
    frame = env.frame
    names = {**env.feature_names_map(), FREE: FREE}
    qs = frame.to_user(np.array([p.sample for p in pieces]).reshape(-1, 2)).tolist()
    eps = (np.array([p.eps for p in pieces], dtype=float) / float(frame.scale)).tolist()
    lines = frame.geometry_to_user(np.array([p.geometry for p in pieces], dtype=object))
    return [(p.id, p.regions, p.curves, p.kind, tuple(names.get(f, f) for f in p.features),
             shapely.to_wkb(g), (q[0], q[1]), p.normal, e, p.verified)
            for p, q, e, g in zip(pieces, qs, eps, lines, strict=True)]


def _fields(pieces) -> list[tuple]:
    return [(p.id, p.regions, p.curves, p.kind, p.features, shapely.to_wkb(p.geometry),
             p.sample, p.normal, p.eps, p.verified) for p in pieces]


def _decompose_with_reference(monkeypatch, env, lss):
    """``decompose(env, lss)`` and the pieces the former construction made from the same
    inputs (internal frame)."""
    refs = []
    made = pieces_mod.make_pieces

    def spy(*args):
        refs.append(_reference_pieces(*args))
        return made(*args)

    monkeypatch.setattr(pipeline, "make_pieces", spy)
    dec = decompose(env, lss)
    return dec, refs[0]


def _scaled_map() -> tuple[Environment, float]:
    """Offset, scaled, renumbered (a straight vertex): every conversion applies."""
    k, o = 7.0, np.array([120.0, -35.0])
    ring = np.array([[-0.3, -0.3], [0.0, -0.3], [0.3, -0.3], [0.3, 0.3], [0.05, 0.3],
                     [0.0, 0.1], [-0.3, 0.3]]) * k + o
    hole = np.array([[-0.12, -0.12], [-0.12, 0.0], [0.0, 0.0]]) * k + o
    return Environment(ring, (hole,), "scaled"), 0.2 * k


def _plan():
    plan = floor_plan(40, seed=1)
    return plan, (plan.bounds[2] - plan.bounds[0]) / 6


@pytest.mark.parametrize("case", ["generic", "scaled",
                                  pytest.param("plan", marks=pytest.mark.slow)])
def test_pieces_equal_the_former_objects(monkeypatch, case):
    env, lss = {"generic": (GENERIC.internal, 2.5 * GENERIC.frame.scale),
                "scaled": _scaled_map(), "plan": _plan()}[case]
    dec, ref = _decompose_with_reference(monkeypatch, env, lss)
    assert len(ref) > 5
    if env.is_internal:
        assert _fields(dec.pieces) == _fields(ref)
    else:
        assert _fields(dec.pieces) == _reference_user(ref, env)
    # one by one, by slices and iterated: the same pieces
    assert [dec.pieces[i] for i in range(len(ref))] == list(dec.pieces)
    assert dec.pieces[1::3] == tuple(dec.pieces)[1::3]
    assert dec.pieces[-1] == tuple(dec.pieces)[-1]


def test_renamed_features_read_the_file_names(monkeypatch):
    """The scaled map is renumbered: some piece's features differ from the internal ones."""
    env, lss = _scaled_map()
    dec, ref = _decompose_with_reference(monkeypatch, env, lss)
    assert any(p.features != r.features for p, r in zip(dec.pieces, ref, strict=True))


def test_sequence_equals_and_hashes_as_the_tuple():
    dec = decompose(SQUARE_HOLE, 1.0)
    pieces = dec.pieces
    as_tuple = tuple(pieces)
    assert pieces == as_tuple and as_tuple == pieces and hash(pieces) == hash(as_tuple)
    assert pieces[0] == pieces[0] and hash(pieces[0]) == hash(pieces[0])
    assert pieces[0] != pieces[1]
    assert pieces[2] in pieces and as_tuple[-1] in pieces
    other = Piece(0, (7, 8), (), "?", (), None, (0.0, 0.0), (1.0, 0.0), 1.0)
    assert other not in pieces and "P0" not in pieces
    assert repr(pieces) == repr(as_tuple)
    assert pieces[len(pieces):] == () and pieces[::-1] == as_tuple[::-1]
    with pytest.raises(IndexError):
        pieces[len(pieces)]
    with pytest.raises(IndexError):
        pieces[-len(pieces) - 1]
    copy = pickle.loads(pickle.dumps(dec))
    assert copy.pieces == pieces
    assert _fields(copy.pieces) == _fields(pieces)


def test_columns_read_by_g_the_crossings_and_the_self_check():
    """The region pairs, the crossings and the unverified pieces read from the columns equal
    those read from the objects (also with a piece marked unverified)."""
    dec = decompose(GENERIC, 2.5)
    objs = tuple(dec.pieces)
    regs = piece_regions(dec)
    assert regs.dtype == np.int64 and regs.tolist() == [list(p.regions) for p in objs]
    assert not regs.flags.writeable  # the column itself: G must not write it
    q, n, eps = dec.piece_crossings()
    assert q.tolist() == [list(p.sample) for p in objs]
    assert n.tolist() == [list(p.normal) for p in objs]
    assert eps.tolist() == [p.eps for p in objs]
    table = dec.pieces._table
    table.ok = table.ok.copy()
    table.ok[[1, 4]] = False
    got = verify._unverified(dec.pieces)
    assert got == [p for p in dec.pieces if not p.verified] == [dec.pieces[1], dec.pieces[4]]
    assert verify._unverified(tuple(dec.pieces)) == got


def _describe_reference(sptr, ssrc, which, curves):
    """Each chain's description through a dict of curve tuples (the former ``describe``)."""
    flat, ptr = ssrc.tolist(), sptr.tolist()
    out = []
    for i in which.tolist():
        key = tuple(flat[ptr[i]:ptr[i + 1]])
        kinds = "".join(sorted({curves[c].kind for c in key})) or "?"
        feats = tuple(dict.fromkeys(f for c in key for f in curves[c].features))
        out.append((key, kinds, feats))
    return out


class _FakeCurve:
    def __init__(self, rng):
        self.kind = "ABCD"[rng.integers(4)]
        self.features = tuple(f"E{x}" for x in rng.integers(0, 6, rng.integers(0, 3)))


@pytest.mark.parametrize("seed", range(5))
def test_describe_chains_against_a_dict_of_tuples(seed):
    rng = np.random.default_rng(seed)
    curves = [_FakeCurve(rng) for _ in range(8)]
    nchain = 300
    size = rng.integers(0, 4, nchain)  # many repeats, size 0 included
    src = [np.sort(rng.choice(8, s, replace=False)) for s in size.tolist()]
    ssrc = np.concatenate(src).astype(np.int64)
    sptr = np.concatenate(([0], np.cumsum(size))).astype(np.int64)
    which = np.sort(rng.choice(nchain, 200, replace=False))
    desc, descs = _describe_chains(sptr, ssrc, which, curves)
    assert [descs[d] for d in desc.tolist()] == _describe_reference(sptr, ssrc, which, curves)
    assert len(descs) == len(set(descs))  # each distinct description once


@pytest.mark.slow
def test_dictionary_and_piece_between_read_the_columns():
    """The full dictionary's pieces (made from the columns) equal each piece's own
    dictionary and line; the simulator's piece between two regions is the first such piece."""
    from tether.sim.simulate import _piece_between

    env, lss = _scaled_map()
    dec = decompose(env, lss)
    got = dec.to_dict(geometry=True)["pieces"]
    want = [p.to_dict() | {"geometry": shapely.to_wkt(p.geometry, rounding_precision=-1)}
            for p in dec.pieces]
    assert got == want
    for k, p in enumerate(dec.pieces):
        a, b = p.regions
        first = next(q.name for q in dec.pieces if set(q.regions) == {a, b})
        assert _piece_between(dec, a, b) == _piece_between(dec, b, a) == first
        assert k == 0 or _piece_between(dec, a, a) == "P?"
