"""The region loop of ``_decompose`` (regions, chains, crossing candidates) against the
implementations it replaced, kept here as references: the same arrays, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from tether._util import arrays as arrays_mod
from tether._util.arrays import ragged_arange
from tether.curves import critical_curves
from tether.decomposition import arrangement as arrangement_mod
from tether.decomposition import faces as faces_mod
from tether.decomposition import pieces
from tether.decomposition import regions as regions_mod
from tether.examples.floorplan import floor_plan
from tether.tolerances import REL_CURVE_TOL


def _chains_reference(arr, face_region):
    """``_chains`` as it was: rows grouped by hashing (``_row_ids``), each row linked to its
    group's first."""
    fr = np.append(face_region, -1)
    ra, rb = fr[arr.part_faces[:, 0]], fr[arr.part_faces[:, 1]]
    parts = np.flatnonzero((ra >= 0) & (rb >= 0) & (ra != rb))
    if len(parts) == 0:
        return arrangement_mod.Chains(np.zeros((0, 2), np.int64), np.zeros(1, np.int64),
                         np.zeros(0, np.int64))
    lo, hi = np.minimum(ra, rb), np.maximum(ra, rb)
    first_id, last_id = arr.end_ids()
    end_id = np.concatenate((first_id[parts], last_id[parts]))
    sptr, sflat = arr.sources()
    nsrc = sptr[parts + 1] - sptr[parts]
    src = sflat[ragged_arange(sptr[parts], nsrc)]
    local = np.tile(np.repeat(np.arange(len(parts)), nsrc), 2)
    end_of_row = np.concatenate((np.repeat(end_id[: len(parts)], nsrc),
                                 np.repeat(end_id[len(parts):], nsrc)))
    src_row = np.tile(src, 2)
    k = parts[local]
    group, first = arrays_mod.row_ids(np.column_stack((lo[k], hi[k], end_of_row, src_row)))
    comp = arrays_mod.components(len(parts), local, local[first][group])
    order = np.lexsort((parts, comp))
    comp_o, parts_o = comp[order], parts[order]
    starts = np.flatnonzero(np.r_[True, comp_o[1:] != comp_o[:-1]])
    stops = np.r_[starts[1:], len(parts_o)]
    head = parts_o[starts]
    rank = np.lexsort((head, hi[head], lo[head]))
    h = head[rank]
    size = (stops - starts)[rank]
    return arrangement_mod.Chains(np.column_stack((lo[h], hi[h])), np.r_[0, np.cumsum(size)],
                     parts_o[ragged_arange(starts[rank], size)])


@pytest.fixture(scope="module")
def arrangement():
    env = floor_plan(60, seed=3).internal
    lss = 0.1 * (env.bounds[2] - env.bounds[0])
    tol = REL_CURVE_TOL * env.diameter
    return arrangement_mod.arrangement(env, critical_curves(env, lss, REL_CURVE_TOL), tol)


@pytest.mark.parametrize("nreg", [1, 3, 40, 10**6])
def test_chains_equal_reference(arrangement, nreg):
    """Random regions over the faces (some faces in none): the same chains."""
    rng = np.random.default_rng(nreg)
    nf = len(arrangement.faces)
    for _ in range(3):
        face_region = rng.integers(0, min(nreg, nf), nf)
        face_region[rng.random(nf) < 0.1] = -1
        got, want = pieces.make_chains(arrangement, face_region), _chains_reference(arrangement,
                                                                            face_region)
        assert len(want) > 0 or nreg == 1
        for g, w in ((got.pair, want.pair), (got.ptr, want.ptr), (got.parts, want.parts)):
            assert np.array_equal(g, w)


def test_equal_row_links_connect_exactly_the_equal_rows():
    rng = np.random.default_rng(1)
    for spans in ((5, 3, 7), (2**40, 2**30, 4)):  # packed, then hashed (too wide to pack)
        cols = tuple(rng.integers(0, min(s, 6), 3000) * (s // 6 + 1) for s in spans)
        u, v = pieces._equal_row_links(cols)
        rows = np.column_stack(cols)
        assert np.all(rows[u] == rows[v])
        comp = arrays_mod.components(len(rows), u, v)
        _, want = np.unique(rows, axis=0, return_inverse=True)
        # the same partition: equal rows together, different rows apart
        pairs = {(int(a), int(b)) for a, b in zip(comp, want.ravel(), strict=True)}
        assert len(pairs) == len(set(comp.tolist())) == len(set(want.ravel().tolist()))


def _number_regions_reference(arr, flat, size, pts, clear):
    """``_number_regions`` as it was (face lists first, a lexsort for the best faces)."""
    face_area = shapely.area(arr.faces)
    starts = (np.cumsum(size) - size).tolist()
    flat_list = flat.tolist()
    lists = [flat_list[a:a + n] for a, n in zip(starts, size.tolist(), strict=True)]
    group = np.repeat(np.arange(len(lists)), size)
    order = np.lexsort((-clear[flat], group))
    head = np.r_[True, group[order][1:] != group[order][:-1]]
    best = flat[order[head]]
    area = np.bincount(group, weights=face_area[flat], minlength=len(lists))
    for g in np.flatnonzero(size >= 8).tolist():
        area[g] = face_area[lists[g]].sum()
    point = np.round(pts[best], 9)
    rank = np.lexsort((point[:, 1], point[:, 0]))
    face_region = np.full(len(arr.faces), -1, dtype=np.int64)
    region_of_group = np.empty(len(lists), np.int64)
    region_of_group[rank] = np.arange(len(lists))
    face_region[flat] = region_of_group[group]
    return {"lists": lists, "best": best, "area": area, "point": point, "rank": rank,
            "face_region": face_region}


def test_number_regions_equal_reference(arrangement):
    """Random groups of faces (some of 8 or more), clearances with ties: the same numbering
    and the regions' face groups as the face lists give them."""
    rng = np.random.default_rng(5)
    nf = len(arrangement.faces)
    pts, clear = faces_mod.face_points(arrangement.faces, 1e-9)
    clear = np.round(clear, 3)  # ties
    faces = rng.permutation(nf)[: nf - 10]
    size = rng.integers(1, 12, nf)
    size = size[np.cumsum(size) <= len(faces)]
    flat = faces[: size.sum()]
    got = regions_mod._number_regions(arrangement, flat, size, pts, clear)
    want = _number_regions_reference(arrangement, flat, size, pts, clear)
    assert (size >= 8).any() and len(size) > 10
    for k in ("best", "area", "point", "rank", "face_region"):
        assert np.array_equal(got[k], want[k]), k
    # the regions' polygons: each region's group of faces (first face, or all of a union)
    shapes = regions_mod._region_shapes(arrangement, flat, size, got["rank"], None)
    lists = want["lists"]
    assert len(shapes._unions) == sum(len(lists[g]) > 1 for g in want["rank"]) > 10
    for rid, g in enumerate(want["rank"].tolist()):
        assert shapes._geoms[rid].wkb == arrangement.faces[lists[g][0]].wkb  # packed: equal
        if len(lists[g]) > 1:
            assert shapes._unions[rid].tolist() == arrangement.faces[lists[g]].tolist()
        else:
            assert rid not in shapes._unions
    empty = regions_mod._region_shapes(arrangement, flat[:0], size[:0], got["rank"][:0], None)
    assert len(empty) == 0 and empty._unions is None


def test_best_per_group_is_the_lexsort_head():
    rng = np.random.default_rng(6)
    group = np.sort(rng.integers(0, 300, 3000))
    group = np.unique(group, return_inverse=True)[1].ravel()
    value = rng.integers(0, 4, 3000).astype(float)  # many ties
    for v in (value, np.where(rng.random(3000) < 0.05, np.nan, value)):
        order = np.lexsort((-v, group))
        want = order[np.r_[True, group[order][1:] != group[order][:-1]]]
        assert np.array_equal(regions_mod._best_per_group(v, group), want)


def test_descending_within_runs_is_the_lexsort():
    rng = np.random.default_rng(8)
    for n_runs, top in ((500, 6), (200, 30), (1, 3), (50, 1)):
        count = rng.integers(0, top + 1, n_runs)
        start = np.cumsum(count) - count
        run = np.repeat(np.arange(n_runs), count)
        value = rng.integers(0, 5, len(run)).astype(float)  # many ties
        value[rng.random(len(run)) < 0.05] = -np.inf
        for v in (value, np.where(rng.random(len(run)) < 0.03, np.nan, value)):
            assert np.array_equal(pieces._descending_within_runs(v, start, count),
                                  np.lexsort((-v, run)))
    assert len(pieces._descending_within_runs(np.zeros(0), np.zeros(0, int), np.zeros(0, int))) == 0


def _part_candidates_reference(arr, need, tol, lss):
    """``_part_candidates`` as it was, uncached: a lexsort of the segments."""
    sa, sb, sowner, tree = arr.segments()
    seg = np.flatnonzero(need[sowner])
    a, b, part = sa[seg], sb[seg], sowner[seg]
    ln = np.hypot(*(b - a).T)
    order = np.lexsort((-ln, part))
    part_o = part[order]
    head = np.flatnonzero(np.r_[True, part_o[1:] != part_o[:-1]])
    rank = np.arange(len(order)) - np.repeat(head, np.diff(np.r_[head, len(order)]))
    take = order[(rank < 6) & (ln[order] > 0)]
    Q = 0.5 * (a[take] + b[take])
    mine = part[take]
    return Q, mine, pieces._clearance(Q, mine, sa, sb, sowner, tree, max(1e3 * tol, 1e-3 * lss))


def _crossing_candidates_reference(arr, chains, tol, lss):
    """``_crossing_candidates`` as it was: a lexsort of all the rows by chain, clearance."""
    part_chain = np.full(len(arr.parts), -1)
    part_chain[chains.parts] = np.repeat(np.arange(len(chains)), chains.size)
    Q, mine, clear = _part_candidates_reference(arr, part_chain >= 0, tol, lss)
    chain = part_chain[mine]
    ok = np.flatnonzero(clear >= 4 * tol)
    ok = ok[np.lexsort((-clear[ok], chain[ok]))]
    ch = chain[ok]
    head = np.flatnonzero(np.r_[True, ch[1:] != ch[:-1]]) if len(ch) else np.zeros(0, int)
    rank = np.arange(len(ch)) - np.repeat(head, np.diff(np.r_[head, len(ch)]))
    ok = ok[rank < 8]
    eps = np.minimum(0.25 * (clear[ok] - tol), max(50 * tol, 1e-4 * lss))
    ptr = np.searchsorted(chain[ok], np.arange(len(chains) + 1))
    return pieces.Candidates(ptr, Q[ok].reshape(-1, 2), eps)


@pytest.mark.slow
@pytest.mark.parametrize("nreg, k", [(3, 30), (40, 1), (10**6, 1)])
def test_crossing_candidates_equal_reference(nreg, k):
    """Chains of random regions (on a fresh arrangement each: no cache), with the clearance
    threshold hit or not: the same candidates, bit for bit."""
    env = floor_plan(40, seed=2).internal
    lss = 0.12 * (env.bounds[2] - env.bounds[0])
    for tol in (k * REL_CURVE_TOL * env.diameter,):
        curves = critical_curves(env, lss, REL_CURVE_TOL)
        arr = arrangement_mod.arrangement(env, curves, tol)
        rng = np.random.default_rng(nreg)
        nf = len(arr.faces)
        face_region = rng.integers(0, min(nreg, nf), nf)
        chains = pieces.make_chains(arr, face_region)
        got = pieces.crossing_candidates(arr, chains, tol, lss)
        want = _crossing_candidates_reference(arrangement_mod.arrangement(env, curves, tol),
                                              chains, tol, lss)
        assert len(want.eps) > 50 and (want.count < want.count.max()).any()
        for g, w in ((got.ptr, want.ptr), (got.q, want.q), (got.eps, want.eps)):
            assert np.array_equal(g, w)


@pytest.mark.slow
def test_isolated_regions_are_those_of_the_chains():
    """The regions no chain of which has a candidate, as the loop found them before: from
    the chains and their candidates. Random regions, and the smallest faces as regions of
    their own (some isolated at the larger tolerances)."""
    env = floor_plan(40, seed=5).internal
    lss = 0.12 * (env.bounds[2] - env.bounds[0])
    curves = critical_curves(env, lss, REL_CURVE_TOL)
    seen = 0
    for k in (1, 300):
        tol = k * REL_CURVE_TOL * env.diameter
        arr = arrangement_mod.arrangement(env, curves, tol)
        rng = np.random.default_rng(k)
        for nreg in (2, 30):
            face_region = rng.integers(0, nreg, len(arr.faces))
            face_region[rng.random(len(face_region)) < 0.2] = -1
            small = np.argsort(shapely.area(arr.faces))[:40]
            face_region[small] = nreg + np.arange(40)
            chains = pieces.make_chains(arr, face_region)
            cands = pieces.crossing_candidates(arr, chains, tol, lss)
            touched = np.zeros(nreg + 40, bool)
            touched[chains.pair[cands.count > 0].ravel()] = True
            want = set(np.flatnonzero(~touched).tolist())
            assert regions_mod._isolated_regions(arr, face_region, nreg + 40, tol, lss) == want
            seen += len(want)
    assert seen
