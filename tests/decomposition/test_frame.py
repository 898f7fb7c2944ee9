"""The results reported in the user's frame, and the collector's pause around the computation."""

from __future__ import annotations

import gc

import numpy as np
import pytest

from tether._util.memory import gc_paused


class _Node:
    """A small object able to form a reference cycle."""

    def __init__(self) -> None:
        self.other: object = None


@pytest.mark.slow
def test_gc_paused_restores_the_collector_and_freezes_nothing():
    was = gc.isenabled()
    gc.enable()
    try:
        with gc_paused():
            assert not gc.isenabled()
            with gc_paused():  # nested: the inner pause leaves the collector off
                pass
            assert not gc.isenabled()
            kept = [_Node() for _ in range(1000)]
        assert gc.isenabled()
        assert gc.get_freeze_count() == 0
        # the objects made during the pause were promoted, not lost: a cycle among them is
        # still collected by a full collection
        a, b = kept[0], kept[1]
        a.other, b.other = b, a
        del kept, a, b
        assert gc.collect() >= 2
    finally:
        if not was:
            gc.disable()


def test_gc_paused_leaves_a_callers_frozen_objects_frozen():
    was = gc.isenabled()
    gc.enable()
    gc.freeze()
    try:
        frozen = gc.get_freeze_count()
        with gc_paused():
            pass
        assert gc.get_freeze_count() == frozen
    finally:
        gc.unfreeze()
        if not was:
            gc.disable()


def _public(dec) -> dict:
    """Every public value of a decomposition, geometry as WKB (exact)."""
    import numpy as np
    import shapely

    return {
        "dict": dec.to_dict(geometry=True),
        "regions": [(r.id, shapely.to_wkb(r.polygon), r.area, r.point, r.structure, r.cells)
                    for r in dec.regions],
        "cells": list(dec.cells),
        "pieces": [(p.id, p.regions, p.curves, p.kind, p.features, shapely.to_wkb(p.geometry),
                    p.sample, p.normal, p.eps, p.verified) for p in dec.pieces],
        "curves": [(c.to_dict(), [p.tolist() for p in c.polylines],
                    [np.asarray(t).tolist() for t in c.params])
                   for c in dec.curves],
        "tol": (dec.curve_tol, dec.unresolved_pieces, dec.lss),
    }


@pytest.mark.slow
def test_user_frame_results_equal_the_direct_computation_in_an_identity_frame():
    import numpy as np

    from tether import Environment
    from tether.decomposition import decompose

    # centred on the origin, diagonal near 1, no straight vertex: the internal frame is the
    # identity and the internal map is the map itself (another object): decompose(env) goes
    # through the user-frame reporting, decompose(env.internal) does not
    env = Environment([[-0.3, -0.3], [0.3, -0.3], [0.3, 0.3], [0.05, 0.3], [0.0, 0.1],
                       [-0.3, 0.3]], ([[-0.12, -0.12], [-0.12, 0.0], [0.0, 0.0]],), "id")
    assert not env.is_internal
    assert env.frame.scale == 1.0 and not np.any(env.frame.origin)
    mine, direct = decompose(env, 0.2), decompose(env.internal, 0.2)
    assert len(mine.regions) > 5 and len(mine.pieces) > 5
    assert _public(mine) == _public(direct)
    pts = np.random.default_rng(0).uniform(-0.3, 0.3, size=(200, 2))
    ang = np.linspace(0, 6, 200)
    assert mine.region_at(pts).tolist() == direct.region_at(pts).tolist()
    assert mine.cell_at(pts, ang) == direct.cell_at(pts, ang)


@pytest.mark.slow
def test_renumbered_map_reports_the_direct_computation_renamed():
    """A straight vertex renumbers the features: the user-frame results are the internal
    map's, features renamed through ``feature_names_map`` and codes through ``code_map``
    (the frame is the identity here, so coordinates are equal)."""
    import numpy as np
    import shapely

    from tether import Environment
    from tether.decomposition import FREE, decompose

    env = Environment([[-0.3, -0.3], [0.0, -0.3], [0.3, -0.3], [0.3, 0.3], [0.05, 0.3],
                       [0.0, 0.1], [-0.3, 0.3]],
                      ([[-0.12, -0.12], [-0.12, 0.0], [0.0, 0.0]],), "straight")
    assert env.frame.scale == 1.0 and not np.any(env.frame.origin)
    assert env.internal.n == env.n - 1  # the vertex (0, -0.3) is straight
    mine, direct = decompose(env, 0.2), decompose(env.internal, 0.2)
    names = {**env.feature_names_map(), FREE: FREE}
    cm = env.code_map

    def cell(cid: str) -> str:
        r, s, e = cid[1:-1].split(",")
        return f"({r},{names[s]},{names[e]})"

    assert len(mine.regions) == len(direct.regions) > 5
    for a, b in zip(mine.regions, direct.regions, strict=True):
        assert shapely.to_wkb(a.polygon) == shapely.to_wkb(b.polygon)
        assert (a.area, a.point) == (b.area, b.point)
        assert a.cells == tuple(cell(c) for c in b.cells)
        assert a.structure == (b.structure if isinstance(b.structure, str) else
                               frozenset((int(cm[x]), int(cm[y])) for x, y in b.structure))
    assert [(c.id, c.region, c.start_feature, c.end_feature) for c in mine.cells] == [
        (cell(c.id), c.region, names[c.start_feature], names[c.end_feature])
        for c in direct.cells]
    for p, q in zip(mine.pieces, direct.pieces, strict=True):
        assert shapely.to_wkb(p.geometry) == shapely.to_wkb(q.geometry)
        assert (p.sample, p.normal, p.eps, p.regions, p.curves, p.kind) == (
            q.sample, q.normal, q.eps, q.regions, q.curves, q.kind)
        assert p.features == tuple(names.get(f, f) for f in q.features)
    arcs, inner = mine.crossing_arcs(), direct.crossing_arcs()
    assert np.array_equal(arcs.start_code, cm[inner.start_code])
    assert np.array_equal(arcs.end_code, cm[inner.end_code])
    assert np.array_equal(arcs.start, inner.start) and np.array_equal(arcs.end, inner.end)


def _scaled_map():
    """A map whose internal frame is not the identity (offset, scaled) and renumbered (a
    straight vertex)."""
    from tether import Environment

    k, o = 7.0, np.array([120.0, -35.0])
    ring = np.array([[-0.3, -0.3], [0.0, -0.3], [0.3, -0.3], [0.3, 0.3], [0.05, 0.3],
                     [0.0, 0.1], [-0.3, 0.3]]) * k + o
    hole = np.array([[-0.12, -0.12], [-0.12, 0.0], [0.0, 0.0]]) * k + o
    env = Environment(ring, (hole,), "scaled")
    assert env.frame.scale != 1.0 and np.any(env.frame.origin)
    return env, 0.2 * k


def _converted(dec) -> tuple[bool, bool]:
    """Whether the regions' polygons and the pieces' lines are in the map's frame yet."""
    return dec.regions[0]._polygon.converted, dec.pieces[0]._geometry.converted


@pytest.mark.slow
def test_geometries_are_converted_lazily_all_at_once_and_equal_the_eager_conversion():
    """The polygons and lines are kept in the internal frame until first read, then all
    converted at once: bit for bit (WKB) the eager conversion of the internal decomposition's
    geometries; building G and analyzing (without the self-check) convert nothing."""
    import shapely

    from tether.analysis import analyze, build_graph
    from tether.decomposition import decompose

    env, lss = _scaled_map()
    dec = decompose(env, lss)
    inner = decompose(env.internal, lss * env.frame.scale)
    assert len(dec.regions) > 5 and len(dec.pieces) > 5
    assert _converted(dec) == (False, False)
    analyze(dec, build_graph(dec), self_check=False)
    assert _converted(dec) == (False, False)
    eager = env.frame.geometry_to_user(np.array([r.polygon for r in inner.regions]))
    assert dec.regions[3].polygon.equals(eager[3])  # one read converts the batch
    assert _converted(dec) == (True, False)
    assert all(shapely.is_prepared(r.polygon) for r in dec.regions)
    assert [shapely.to_wkb(r.polygon) for r in dec.regions] == shapely.to_wkb(eager).tolist()
    eager = env.frame.geometry_to_user(np.array([p.geometry for p in inner.pieces]))
    assert [shapely.to_wkb(p.geometry) for p in dec.pieces] == shapely.to_wkb(eager).tolist()
    assert _converted(dec) == (True, True)
    # the holder is shared: one array, read by id
    assert len({id(r._polygon) for r in dec.regions}) == 1
    assert dec.regions[2].polygon is dec.regions[2].polygon


@pytest.mark.slow
def test_lazy_geometries_pickle_and_locate_as_the_converted_ones():
    """Pickling before the first read keeps the internal geometries and the frame: the copy
    converts to the same bits; point location and the full dictionary are unchanged."""
    import pickle

    import shapely

    from tether.decomposition import decompose

    env, lss = _scaled_map()
    dec = decompose(env, lss)
    copy = pickle.loads(pickle.dumps(dec))
    assert _converted(copy) == (False, False)
    pts = np.random.default_rng(1).uniform(env.vertices.min(0), env.vertices.max(0),
                                           size=(300, 2))
    got = copy.region_at(pts)  # converts the copy's polygons
    assert (got >= 0).sum() > 100
    assert got.tolist() == dec.region_at(pts).tolist()
    assert copy.to_dict(geometry=True) == dec.to_dict(geometry=True)
    again = pickle.loads(pickle.dumps(dec))  # pickled converted
    assert _converted(again) == (True, True)
    for a, b in zip(again.regions, dec.regions, strict=True):
        assert shapely.to_wkb(a.polygon) == shapely.to_wkb(b.polygon)
    assert repr(copy.regions[0]) == repr(dec.regions[0])
    assert repr(copy.pieces[0]) == repr(dec.pieces[0])


def test_self_check_converts_only_the_regions_it_samples():
    """The self-check's few regions are converted alone (the batch stays as made) and sampled
    exactly as from the converted batch."""
    import shapely

    from tether.decomposition import decompose, sample_in_regions, self_check
    from tether.decomposition.verify import _polygons

    env, lss = _scaled_map()
    dec = decompose(env, lss)
    few = [dec.regions[i] for i in (1, 4)]
    lone = _polygons(few)
    assert self_check(dec, regions=3).ok
    a = sample_in_regions(dec, 5, seed=3, regions=[1, 4])
    assert _converted(dec) == (False, False)
    assert [shapely.to_wkb(p) for p in lone] == [shapely.to_wkb(r.polygon) for r in few]
    assert _converted(dec) == (True, False)
    b = sample_in_regions(dec, 5, seed=3, regions=[1, 4])
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])


def test_curves_converted_at_once_equal_each_curves_own_conversion():
    """:meth:`UserFrame.curves` (all polylines and parameters converted in one array) gives,
    bit for bit, the curves of :meth:`Curve.to_user` one by one, on a scaled, offset and
    renumbered map (C and D parameters are lengths: scaled; the others kept)."""
    from tether.curves import critical_curves
    from tether.decomposition.frame import UserFrame

    env, lss = _scaled_map()
    frame = UserFrame(env, lss)
    inner = critical_curves(env.internal, lss * env.frame.scale)
    assert {c.kind for c in inner} >= {"A", "B", "C"}
    mine = frame.converted_curves(inner)
    assert frame.converted_curves([]) == ()
    assert len(mine) == len(inner)

    def same(x, y) -> bool:
        if isinstance(x, np.ndarray):
            return type(y) is np.ndarray and x.shape == y.shape and x.tobytes() == y.tobytes()
        if isinstance(x, tuple):
            return (type(y) is tuple and len(x) == len(y)
                    and all(same(a, b) for a, b in zip(x, y, strict=True)))
        return type(x) is type(y) and x == y

    for c, got in zip(inner, mine, strict=True):
        ref = c.to_user(env.frame, frame.names)
        for f in ("id", "kind", "features", "domain", "intervals", "polylines", "params",
                  "index"):
            assert same(getattr(got, f), getattr(ref, f)), f
        assert got.family is ref.family and got.frame is ref.frame


@pytest.mark.slow
def test_user_curves_converted_on_first_read_once():
    """Decomposing in a user frame leaves the curves unconverted until one is read; then all
    are converted once (the same objects on every read), equal to the eager conversion, and
    the sequence behaves (and pickles) as the tuple of them."""
    import pickle

    from tether.decomposition import decompose

    env, lss = _scaled_map()
    dec = decompose(env, lss)
    curves = dec.curves
    assert curves._done is None and len(curves) > 10 and curves._done is None
    assert dec.counts["curves"] == len(curves)
    first = curves[0]
    assert curves._done is not None and curves._inner is None
    assert curves[0] is first and curves[-1] is tuple(curves)[-1]
    assert curves[1:3] == tuple(curves)[1:3]
    assert curves == tuple(curves) and hash(curves) == hash(tuple(curves))
    assert [c.name for c in curves] == [c.name for c in pickle.loads(pickle.dumps(dec)).curves]
    assert type(pickle.loads(pickle.dumps(curves))) is tuple
    assert pickle.loads(pickle.dumps(dec)).curves[0].polylines[0].tolist() == \
        first.polylines[0].tolist()
    # the same numbers as converting each curve on its own
    from tether.decomposition.frame import UserFrame

    names = UserFrame(env, lss).names
    fresh = decompose(env, lss)
    ref = fresh.curves._inner
    for c, mine in zip(ref, curves, strict=True):
        want = c.to_user(env.frame, names)
        assert mine.features == want.features and mine.intervals == want.intervals
        assert all(np.array_equal(a, b) for a, b in zip(mine.polylines, want.polylines,
                                                        strict=True))
