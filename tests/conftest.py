"""Shared maps and strategies for the tests."""

from __future__ import annotations

import math
import os
import sys
from concurrent.futures import Executor, Future

import numpy as np
import pytest
from hypothesis import settings
from hypothesis import strategies as st

from tether import Environment

# The fast tier runs often: keep the compiled (and assertion-rewritten) modules in __pycache__
# (ignored by git) between runs even where PYTHONDONTWRITEBYTECODE is set; this halves the
# collection (about 12 s to 7 s on the 2-core machine).
sys.dont_write_bytecode = False


# CI runs the property tests on a fixed sequence of examples (HYPOTHESIS_PROFILE=ci, set by
# .ci/run), so that a landing never depends on luck; locally each run explores new examples and
# keeps the failures it finds in .hypothesis/ to replay them.
settings.register_profile("ci", derandomize=True, print_blob=True)
settings.register_profile("dev", print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "dev"))

SQUARE_HOLE = Environment([[0, 0], [12, 0], [12, 12], [0, 12]], ([[4, 4], [4, 6], [6, 6], [6, 4]],),
                          "square_hole")
CONVEX = Environment([[0, 0], [10, 0], [13, 5], [8, 9], [1, 7]], (), "convex")
L_SHAPE = Environment([[0, 0], [10, 0], [10, 4], [4, 4], [4, 10], [0, 10]], (), "L")


def star(n: int = 7, r_out: float = 5.0, r_in: float = 2.2) -> np.ndarray:
    t = np.linspace(0, 2 * math.pi, 2 * n, endpoint=False)
    r = np.where(np.arange(2 * n) % 2 == 0, r_out, r_in)
    return np.column_stack((r * np.cos(t), r * np.sin(t)))


STAR_HOLE = Environment(star(), ([[-0.5, -0.5], [-0.5, 0.5], [0.5, 0.5], [0.5, -0.5]],),
                        "star_hole")
GENERIC = Environment(
    [[0, 0], [9.3, 0.4], [11.1, 6.2], [7.4, 5.1], [6.2, 10.3], [0.6, 8.8], [2.1, 4.4]],
    ([[3.1, 2.2], [4.9, 1.7], [4.2, 3.6]], [[8.0, 1.8], [9.1, 2.3], [8.7, 3.5], [7.6, 3.0]]),
    "generic",
)
MAPS = [CONVEX, L_SHAPE, SQUARE_HOLE, STAR_HOLE, GENERIC]


@pytest.fixture(params=MAPS, ids=lambda e: e.name)
def any_map(request) -> Environment:
    return request.param


def interior_points(env: Environment, m: int, seed: int, margin: float = 1e-6) -> np.ndarray:
    """``m`` uniform random points of the free space, farther than ``margin`` from its boundary."""
    rng = np.random.default_rng(seed)
    x0, y0, x1, y1 = env.bounds
    out = np.zeros((0, 2))
    while len(out) < m:
        pts = rng.uniform([x0, y0], [x1, y1], size=(4 * m, 2))
        ok = env.contains(pts[:, 0], pts[:, 1])
        ok &= env.boundary_distance(pts[:, 0], pts[:, 1]) > margin
        out = np.vstack((out, pts[ok]))
    return out[:m]


@st.composite
def random_maps(draw) -> Environment:
    """Random star-shaped boundary (always simple) with up to two convex holes inside it."""
    k = draw(st.integers(4, 12))
    gaps = draw(st.lists(st.floats(0.2, 1.0), min_size=k, max_size=k))
    t = np.cumsum(gaps)
    t = 2 * math.pi * t / t[-1]
    r = np.array(draw(st.lists(st.floats(3.0, 10.0), min_size=k, max_size=k)))
    boundary = np.column_stack((r * np.cos(t), r * np.sin(t)))
    outer = Environment(boundary)
    holes: list[np.ndarray] = []
    for _ in range(draw(st.integers(0, 2))):
        cx, cy = draw(st.floats(-2, 2)), draw(st.floats(-2, 2))
        rad = draw(st.floats(0.3, 1.2))
        m = draw(st.integers(3, 6))
        rot = draw(st.floats(0, 2 * math.pi))
        a = rot + np.linspace(0, 2 * math.pi, m, endpoint=False)
        hole = np.column_stack((cx + rad * np.cos(a), cy + rad * np.sin(a)))
        from shapely.geometry import Polygon

        hp = Polygon(hole)
        if outer.polygon.buffer(-0.05).contains(hp) and all(
            hp.distance(Polygon(h)) > 0.05 for h in holes
        ):
            holes.append(hole)
    return Environment(boundary, tuple(holes), "random")


def dump_failure(env: Environment, lss: float) -> None:
    """Append a failing random map to the file named by TETHER_DUMP (for reproduction)."""
    import json
    import os

    if os.environ.get("TETHER_DUMP"):
        with open(os.environ["TETHER_DUMP"], "a") as f:
            f.write(json.dumps({"map": env.to_dict(), "lss": lss}) + "\n")


def random_cell_graph(rng, max_regions: int, max_pieces: int, cell_names) -> tuple:
    """A random abstract G for the elimination: 2..``max_regions``-1 regions, each with the
    cells ``cell_names(rng, r)``; up to ``max_pieces``-1 pieces between two regions; each cell
    pair across a piece adjacent with probability one half. Returns ``(region_of, pieces_of,
    partners)`` as :func:`tether.analysis.elimination.fixed_point` takes them."""
    nreg = int(rng.integers(2, max_regions))
    region_of = {}
    for r in range(nreg):
        for name in cell_names(rng, r):
            region_of[name] = r
    ends = rng.integers(0, nreg, (int(rng.integers(1, max_pieces)), 2))
    pieces = [(int(a), int(b)) for a, b in ends if a != b]
    pieces_of = {r: tuple(k for k, pr in enumerate(pieces) if r in pr) for r in range(nreg)}
    partners = {}
    for k, (a, b) in enumerate(pieces):
        ca = [c for c, r in region_of.items() if r == a]
        cb = [c for c, r in region_of.items() if r == b]
        for c in ca + cb:
            partners.setdefault((c, k), [])
        for x in ca:
            for y in cb:
                if rng.random() < 0.5:
                    partners[(x, k)].append(y)
                    partners[(y, k)].append(x)
    return region_of, pieces_of, {k: tuple(v) for k, v in partners.items()}


def arcs_at(dec, p) -> list[tuple]:
    """The free arcs at point ``p`` as ``(start, end, start feature, end feature)``."""
    from tether.arcs import TWO_PI, feature_name, free_arcs_many
    from tether.decomposition import FREE

    t = free_arcs_many(dec.env, [p], dec.lss, check=False)
    if t.full[0]:
        return [(0.0, TWO_PI, FREE, FREE)]
    r = t.rows_of(0)
    return [(s, e, feature_name(dec.env, a), feature_name(dec.env, b))
            for s, e, a, b in zip(t.start[r], t.end[r], t.start_code[r], t.end_code[r],
                                  strict=True)]


def followed_pairs(dec, piece, steps=60) -> set[tuple[str, str]]:
    """Follow every arc from one side of the piece to the other in small steps: an arc at
    step k continues into the arcs at step k+1 it overlaps; compose along the way (the cell
    pairs G must hold across the piece, :mod:`tether.analysis.connectivity`)."""
    from tether.analysis.connectivity import _overlap
    from tether.decomposition import cell_name

    q, n, eps = np.array(piece.sample), np.array(piece.normal), piece.eps
    path = [q + eps * n * (1 - 2 * k / steps) for k in range(steps + 1)]
    start = arcs_at(dec, path[0])
    reach = {i: {i} for i in range(len(start))}
    prev = start
    for p in path[1:]:
        cur = arcs_at(dec, p)
        step = {i: {j for j, b in enumerate(cur) if _overlap(a[0], a[1], b[0], b[1]) > 1e-12}
                for i, a in enumerate(prev)}
        reach = {i: set().union(*(step[k] for k in ks)) if ks else set()
                 for i, ks in reach.items()}
        prev = cur
    ra, rb = piece.regions
    return {(cell_name(ra, *start[i][2:]), cell_name(rb, *prev[j][2:]))
            for i, js in reach.items() for j in js}


def lattice_states(kernel, outer) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(free, safe, maybe)`` masks over every state of ``outer``'s lattice, state by state:
    free, held by ``kernel`` (and free), held by ``outer`` (and free). The brute force the
    undecided band's counts are checked against."""
    g = outer.grid
    pts = np.repeat(g.points, g.n_a, axis=0)
    ang = np.tile(g.angles, len(g.points))
    free = g.free.ravel()
    return free, kernel.contains(pts, ang) & free, outer.contains(pts, ang) & free


class SerialExecutor(Executor):
    """Runs each task at once, in this thread: the tiles' code without processes."""

    def submit(self, fn, /, *args, **kwargs):
        f = Future()
        f.set_result(fn(*args, **kwargs))
        return f


def corner_room_first_field(vt: float) -> tuple:
    """The 10 x 10 room (bundled ``nonconvex_corner``) in its normalized frame and its first
    certified-field guess on a coarse mesh (h 1, 90 orientations, ``vo`` = 1): ``(space, lss,
    field)``, the search's small test case (``tests/game/test_field_lp_*.py``)."""
    from tether.examples import path as example_path
    from tether.game import surveillance_kernel
    from tether.game.certificate import first_field
    from tether.io import load_map

    env = load_map(example_path("nonconvex_corner"))
    space, s = env.internal, env.frame.scale
    kern = surveillance_kernel(space, s, vt, 1.0, h=1.0 * s, orientations=90)
    return space, s, first_field(kern)


def lp_rounds(log: list) -> list:
    """The LP rounds' records of an ``lp_field`` log (those with a slack)."""
    return [e for e in log if "slack" in e]
