"""Structures kept as integer rows (:class:`~tether.decomposition.structure.Structures`) and made
into frozensets only when read, against the plain definition: a frozenset of each point's
``(start_code, end_code)`` pairs."""

from __future__ import annotations

import pickle

import numpy as np
from conftest import GENERIC, interior_points

import tether.decomposition as D
from tether import free_arcs_many, load_map
from tether.arcs import ArcTable
from tether.decomposition import model
from tether.decomposition import structure as structure_mod
from tether.examples import path as example_path
from tether.examples.floorplan import floor_plan


def _plain(table: ArcTable, npts: int) -> list:
    """Each point's structure as the old eager code made it, one point at a time."""
    full = np.asarray(table.full, dtype=bool)
    sets: list[set] = [set() for _ in range(npts)]
    for p, a, b in zip(table.point.tolist(), table.start_code.tolist(), table.end_code.tolist(),
                       strict=True):
        sets[p].add((a, b))
    return [frozenset(s) if s else D.Structure.FULL if full[i] else D.Structure.EMPTY
            for i, s in enumerate(sets)]


def _table(env, lss, n, seed) -> ArcTable:
    pts = interior_points(env, n, seed)
    return free_arcs_many(env.internal, env.frame.to_internal(pts), lss * env.frame.scale,
                          check=False)


def _doubled(table: ArcTable, every: int) -> ArcTable:
    """The table with every ``every``-th row repeated at the end (a set holds it once)."""
    extra = np.arange(0, len(table.point), every)
    return ArcTable(*(np.concatenate((c, c[extra])) for c in (
        table.point, table.start, table.end, table.start_code, table.end_code)), table.full)


def _cases():
    return ((GENERIC, 2.5), (load_map(example_path("gallery")), 2.0), (floor_plan(30, seed=1), 0.6))


def test_structure_ids_equal_exactly_for_equal_structures():
    """Equal ids iff equal structures (repeated pairs too), and each id's structure is the
    plain one, one object per id."""
    for env, lss in _cases():
        inner = env.internal
        for table in (_table(env, lss, 300, seed=5), _doubled(_table(env, lss, 300, seed=5), 3)):
            n = len(table.full)
            want = _plain(table, n)
            ids, structs = D.structure_ids(inner, table, n)
            i, j = (a.ravel() for a in np.meshgrid(np.arange(n), np.arange(n)))
            same = np.array([want[a] == want[b] for a, b in zip(i.tolist(), j.tolist(),
                                                                 strict=True)])
            assert same.sum() > n and not same.all()  # some equal, some not
            assert np.array_equal(ids[i] == ids[j], same)
            got = [structs.structure(k) for k in ids.tolist()]
            assert got == want
            assert all(type(a) is type(b) for a, b in zip(got, want, strict=True))
            assert got == D.structures(inner, table, n)
            by_id = {k: got[x] for x, k in enumerate(ids.tolist())}
            assert all(got[x] is by_id[k] for x, k in enumerate(ids.tolist()))  # shared


def test_structure_rows_are_the_rows_of_the_frozensets():
    """The holder's rows are those ``_set_rows`` flattens from the frozensets, row for row."""
    env, lss = _cases()[2]
    inner = env.internal
    table = _table(env, lss, 400, seed=7)
    ids, structs = D.structure_ids(inner, table, len(table.full))
    base = 2 * inner.n + 1
    mine = structs.rows()
    sets, of = structure_mod.set_rows([structs.structure(k) for k in ids.tolist()], base)
    for x, k in enumerate(ids.tolist()):
        r = of[x]
        assert mine.kind[k] == sets.kind[r]
        assert np.array_equal(mine.pairs[mine.ptr[k]:mine.ptr[k + 1]],
                              sets.pairs[sets.ptr[r]:sets.ptr[r + 1]])


def test_region_structures_made_on_first_read():
    """After decompose no frozenset is made; the regions' structures are each the structure
    sampled at the region's point, shared by equal ones, the pieces' rows those of the
    frozensets, and they survive pickling."""
    dec = D.decompose(load_map(example_path("gallery")), 2.0)
    held = dec.regions[0]._structure
    assert type(held) is structure_mod.Structures and not held._sets
    assert all(r._structure is held for r in dec.regions)
    base = 2 * dec.env.internal.n + 1
    rows, of = model.region_rows(list(dec.regions), base)
    st = [r.structure for r in dec.regions]
    assert len(held._sets) == len(np.unique(held.region[held.region >= 2]))
    sets, of_sets = structure_mod.set_rows(st, base)
    k = np.arange(len(st))
    assert structure_mod.rows_equal(rows, of, sets, of_sets).all()
    pts = np.array([r.point for r in dec.regions])
    want = D.structures(dec.env, free_arcs_many(dec.env, pts, dec.lss, check=False), len(pts))
    assert sum(a == b for a, b in zip(st, want, strict=True)) > 0.9 * len(st)
    ids = held.region.tolist()
    assert all((st[a] is st[b]) == (ids[a] == ids[b]) or (ids[a] < 2 and ids[b] < 2)
               for a in k[:60].tolist() for b in k[:60].tolist())
    copy = pickle.loads(pickle.dumps(dec))
    assert [r.structure for r in copy.regions] == st
