"""The results reported in the user's frame, and the collector's pause around the computation."""

from __future__ import annotations

import gc

from tether.decomposition import gc_paused


class _Node:
    """A small object able to form a reference cycle."""

    def __init__(self) -> None:
        self.other: object = None


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
