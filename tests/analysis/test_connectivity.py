"""G and the elimination on integer arrays against the string-keyed reference they replaced.

The reference below is the dict-of-strings implementation kept verbatim in spirit: partners
built by a Python loop over the edges, the worklist fixed point on string cell ids. Verdicts,
surviving sets, elimination orders (cell, piece, round, because), the string views of G and
the witness region must be exactly equal on the example maps, the floor plans and random maps.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import (
    GENERIC,
    SQUARE_HOLE,
    STAR_HOLE,
    random_cell_graph,
    random_maps,
)
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tether import load_map
from tether.analysis.connectivity import _arc_rows, _cell_index, _overlap, build_graph
from tether.analysis.elimination import analyze, fixed_point
from tether.arcs import free_arcs_many
from tether.decomposition import crossing_points, decompose
from tether.examples import path as example_path
from tether.examples.floorplan import floor_plan
from tether.tolerances import ANGLE_TOL


def ref_partners(dec, edge_list):
    """The partners and pieces_of dicts as the Python loop built them."""
    partners: dict = {}
    pieces_of: dict = {r.id: [] for r in dec.regions}
    for k, piece in enumerate(dec.pieces):
        for r in piece.regions:
            pieces_of[r].append(k)
            for c in dec.regions[r].cells:
                partners[(c, k)] = []
    for ka, kb, p in edge_list:
        partners[(ka, p)].append(kb)
        partners[(kb, p)].append(ka)
    return ({key: tuple(v) for key, v in partners.items()},
            {r: tuple(v) for r, v in pieces_of.items()})


def ref_cell_key(cid):
    parts = cid.strip("()").split(",")
    if len(parts) == 3 and parts[0][:1] == "R" and parts[0][1:].isdigit():
        return (0, int(parts[0][1:]), parts[1], parts[2])
    return (1, cid, "", "")


def ref_fixed_point(region_of, pieces_of, partners):
    """The worklist on dicts of strings, in rounds (the implementation before arrays)."""
    alive = set(region_of)
    rank = {c: i for i, c in enumerate(sorted(region_of, key=ref_cell_key))}
    count = {key: len(ps) for key, ps in partners.items()}
    level = []
    for c in sorted(alive, key=rank.__getitem__):
        for piece in pieces_of[region_of[c]]:
            if count.get((c, piece), 0) == 0:
                level.append((c, piece, None))
                break
    queued = {c for c, _, _ in level}
    removed = []
    rnd = 0
    while level:
        rnd += 1
        for c, piece, because in level:
            alive.discard(c)
            removed.append((c, piece, rnd, because))
        nxt = []
        for c, _, _ in level:
            for piece in pieces_of[region_of[c]]:
                for partner in partners.get((c, piece), ()):
                    key = (partner, piece)
                    count[key] -= 1
                    if count[key] == 0 and partner in alive and partner not in queued:
                        queued.add(partner)
                        nxt.append((partner, piece, c))
        level = sorted(nxt, key=lambda t: rank[t[0]])
    return frozenset(alive), removed


def ref_witness(dec, removed, alive):
    if alive:
        return None
    empty = [r.id for r in dec.regions if not r.cells]
    if empty:
        return empty[0]
    left = {r.id: len(r.cells) for r in dec.regions}
    for c, _, _, _ in removed:
        r = dec.cell(c).region
        left[r] -= 1
        if left[r] == 0:
            return r
    return None


def brute_edges(dec):
    """Every arc pair of the two sides of every piece tested for overlap (all pairs, no
    search: the implementation before the candidate search)."""
    m = len(dec.pieces)
    if m == 0:
        return []
    rows = _arc_rows(dec, crossing_points(*dec.piece_crossings()))
    counts = np.bincount(rows["point"], minlength=2 * m)
    first = np.cumsum(counts) - counts
    a_rows = np.flatnonzero(rows["point"] < m)
    nb = counts[m + rows["point"][a_rows]]
    pair_a = np.repeat(a_rows, nb)
    within = np.arange(len(pair_a)) - np.repeat(np.cumsum(nb) - nb, nb)
    pair_b = np.repeat(first[m + rows["point"][a_rows]], nb) + within
    ov = _overlap(rows["start"][pair_a], rows["end"][pair_a], rows["start"][pair_b],
                  rows["end"][pair_b], rows["full"][pair_a], rows["full"][pair_b])
    keep = np.flatnonzero(ov > ANGLE_TOL)
    k = rows["point"][pair_a[keep]]
    regs = np.array([p.regions for p in dec.pieces]).reshape(-1, 2)
    ca = _cell_index(dec, regs[k, 0], rows["start_code"][pair_a[keep]],
                     rows["end_code"][pair_a[keep]])
    cb = _cell_index(dec, regs[k, 1], rows["start_code"][pair_b[keep]],
                     rows["end_code"][pair_b[keep]])
    ok = (ca >= 0) & (cb >= 0)
    return list(zip(ca[ok].tolist(), cb[ok].tolist(), k[ok].tolist(), strict=True))


def assert_same_as_reference(dec):
    g = build_graph(dec)
    got = list(zip(g.edge_a.tolist(), g.edge_b.tolist(), g.edge_piece.tolist(), strict=True))
    assert got == brute_edges(dec)
    partners, pieces_of = ref_partners(dec, g.edge_list)
    assert list(g.partners.items()) == list(partners.items())
    assert list(g.pieces_of.items()) == list(pieces_of.items())
    assert len(g.edge_list) == g.n_edges
    v = analyze(dec, g, self_check=False)
    region_of = {c.id: c.region for c in dec.cells}
    alive, removed = ref_fixed_point(region_of, pieces_of, partners)
    assert v.surviving == alive
    got = [(e.cell_name, e.piece, e.round, e.because_name) for e in v.eliminated]
    assert got == removed
    for e in v.eliminated:
        a, b = dec.pieces[e.piece].regions
        assert e.escapes_to == (b if a == dec.cell(e.cell).region else a)
    assert v.rounds == max((r for _, _, r, _ in removed), default=0)
    assert v.witness_region == ref_witness(dec, removed, alive)
    assert v.eliminated[0] == list(v.eliminated)[0] if removed else len(v.eliminated) == 0
    return v


EXAMPLES = [(name, f) for name in ("rectangle", "gallery", "convex_corner", "nonconvex_corner")
            for f in (0.05, 0.2, 0.35)]


@pytest.mark.slow
@pytest.mark.parametrize(("name", "frac"), EXAMPLES)
def test_examples_equal_reference(name, frac):
    env = load_map(example_path(name))
    x0, y0, x1, y1 = env.bounds
    assert_same_as_reference(decompose(env, frac * max(x1 - x0, y1 - y0)))


@pytest.mark.parametrize(("env", "lss"), [(SQUARE_HOLE, 2.0), (GENERIC, 2.5), (STAR_HOLE, 1.5)],
                         ids=["square_hole", "generic", "star_hole"])
@pytest.mark.slow
def test_test_maps_equal_reference(env, lss):
    assert_same_as_reference(decompose(env, lss))


@pytest.mark.parametrize("n", [pytest.param(100, marks=pytest.mark.slow),
                               pytest.param(200, marks=pytest.mark.slow),
                               pytest.param(400, marks=pytest.mark.slow)])
def test_floor_plans_equal_reference(n):
    env = floor_plan(n, seed=0)
    assert_same_as_reference(decompose(env, (env.bounds[2] - env.bounds[0]) / 15))


@pytest.mark.slow
@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(env=random_maps(), lss=st.floats(0.5, 6.0))
def test_random_maps_equal_reference(env, lss):
    assert_same_as_reference(decompose(env, lss))


def random_graph(rng):
    """Random regions, cells (names whose string order differs from their numbers') and
    pieces; each cell pair across a piece is adjacent with probability one half."""
    return random_cell_graph(rng, 12, 20, lambda rng, r: [
        f"(R{r},E{k},V{11 - k})"
        for k in rng.choice(12, int(rng.integers(0, 4)), replace=False).tolist()])


@pytest.mark.slow
def test_abstract_fixed_point_equals_reference_on_random_graphs():
    rng = np.random.default_rng(1)
    for _ in range(600):
        region_of, pieces_of, partners = random_graph(rng)
        alive, removed = fixed_point(region_of, pieces_of, partners)
        alive2, removed2 = ref_fixed_point(region_of, pieces_of, partners)
        assert alive == alive2
        assert removed == removed2


@pytest.mark.parametrize(("name", "frac"), [("gallery", 0.1), ("rectangle", 0.2),
                                            ("nonconvex_corner", 0.35)])
def test_crossing_arcs_equal_fresh_evaluation(name, frac):
    """The arcs kept from choosing the crossings are those at the pieces' crossing points:
    same rows, codes and fullness; angles equal up to the frame's rounding."""
    env = load_map(example_path(name))
    x0, y0, x1, y1 = env.bounds
    dec = decompose(env, frac * max(x1 - x0, y1 - y0))
    kept = dec.crossing_arcs()
    fresh = free_arcs_many(env, crossing_points(*dec.piece_crossings()), dec.lss, check=False)
    for f in ("point", "start_code", "end_code", "full"):
        assert np.array_equal(getattr(kept, f), getattr(fresh, f)), f
    for f in ("start", "end"):
        d = np.abs(getattr(kept, f) - getattr(fresh, f))
        assert np.all(np.minimum(d, 2 * np.pi - d) < 1e-9), f


def _with_straight_vertex(env):
    """``env`` with a straight vertex inserted in its first wall: every later feature is
    renumbered (internal ``E9`` is the file's ``E10``: names sort differently)."""
    from tether import Environment

    b = np.asarray(env.boundary, dtype=float)
    mid = (b[0] + b[1]) / 2
    return Environment(np.vstack((b[:1], mid, b[1:])), tuple(env.holes), env.name + "+straight")


def _moved(env, shift=(1000.0, -37.5), scale=3.0):
    from tether import Environment

    return Environment(np.asarray(env.boundary) * scale + shift,
                       tuple(np.asarray(h) * scale + shift for h in env.holes), env.name + "+moved")


def _codes_from_cells(dec):
    """The cells' (region, start code, end code) read back from the Cell objects' names."""
    from tether.arcs import feature_name
    from tether.decomposition import FREE

    code = {feature_name(dec.env, c): c for c in range(2 * dec.env.n)}
    code[FREE] = -1
    return (np.array([c.region for c in dec.cells], dtype=np.int64),
            np.array([code[c.start_feature] for c in dec.cells], dtype=np.int64),
            np.array([code[c.end_feature] for c in dec.cells], dtype=np.int64))


@pytest.mark.slow
@pytest.mark.parametrize("make", ["plain", "straight", "moved", "straight+moved"])
def test_recorded_cell_codes_agree_with_the_cells(make):
    """The integer columns recorded when the cells are made equal the codes named by the Cell
    objects (renumbered and moved maps included), the elimination's rank sorts the cells by
    (region, start name, end name) as strings, and G and the verdict built on the recorded
    columns equal those built on columns read back from the objects."""
    from tether.analysis.elimination import cell_rank

    env = floor_plan(40, seed=1)
    if "straight" in make:
        env = _with_straight_vertex(env)
        assert env.internal.n == env.n - 1
    if "moved" in make:
        env = _moved(env)
    lss = (env.bounds[2] - env.bounds[0]) / 6
    dec = decompose(env, lss)
    assert dec._cell_codes is not None  # recorded by decompose
    got, ref = dec.cell_codes(), _codes_from_cells(dec)
    for a, b in zip(got, ref, strict=True):
        assert a.dtype.kind == "i" and np.array_equal(a, b)  # int32/int16 columns (#25)
    assert np.any(got[1] == -1) == any(r.structure == "FULL" for r in dec.regions)
    rank = cell_rank(dec)
    by_name = sorted(range(len(dec.cells)), key=lambda i: (
        dec.cells[i].region, dec.cells[i].start_feature, dec.cells[i].end_feature))
    assert rank[by_name].tolist() == list(range(len(dec.cells)))
    if "straight" in make:  # cells are listed in internal name order: the file's differs
        assert not np.array_equal(np.argsort(rank), np.arange(len(rank)))
    v = analyze(dec, self_check=False)
    fresh = dataclasses.replace(decompose(env, lss), _cell_codes=None)  # read from the cells
    w = analyze(fresh, self_check=False)
    assert v.surviving == w.surviving and tuple(v.eliminated) == tuple(w.eliminated)
    assert v.graph.edge_list == w.graph.edge_list
