"""The surveillance kernel (issue #11): grid, kernel, look-ups, controller and evader.

Every check compares against something computed another way: the exact rod test, the
surviving cells of ``analyze`` (Prop. 1), set inclusion across speeds, a second resolution,
and the simulator's independent monitor.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import shapely

from tether.analysis import analyze
from tether.arcs import free_arcs, rod_is_free_many
from tether.decomposition import decompose
from tether.environment import Environment
from tether.errors import InvalidParameterError
from tether.game import build_grid, load_kernel, surveillance_kernel
from tether.game.controller import KernelController
from tether.game.evader import KernelEvader
from tether.io import load_map
from tether.sim.protocols import World
from tether.sim.simulate import simulate
from tether.strategies import TARGETS, make_target

EX = Path(__file__).resolve().parents[2] / "src" / "tether" / "examples"


def env_of(name: str) -> Environment:
    return load_map(EX / f"{name}.json")


@pytest.fixture(scope="module")
def room_kernels():
    """The 10 × 10 room (``nonconvex_corner``), lss 1, coarse grid, three speed ratios."""
    env = env_of("nonconvex_corner")
    grid = build_grid(env, 1.0, 0.25, 72)
    return {r: surveillance_kernel(env, 1.0, r, 1.0, grid=grid) for r in (0.3, 0.6, 0.9)}


def test_free_mask_and_runs_match_the_rod_test():
    env = env_of("gallery")
    g = build_grid(env, 2.0, 0.4, 64)
    rng = np.random.default_rng(1)
    i = rng.integers(0, g.n_points, 3000)
    k = rng.integers(0, g.n_a, 3000)
    exact = rod_is_free_many(env, g.points[i], g.angles[k], 2.0)
    # a bin centre within 1e-6 of an arc end (a grazing contact) may go either way
    for b in np.flatnonzero(g.free[i, k] != exact):
        ends = [e for arc in free_arcs(env, g.points[i[b]], 2.0).arcs for e in (arc.start,
                                                                              arc.end)]
        gap = np.abs(np.mod(np.array(ends) - g.angles[k[b]] + math.pi, 2 * math.pi) - math.pi)
        assert gap.min() < 1e-6
    # every bin of a run is free, and so is the rotation between bin centres (sampled)
    for ii, kk in zip(i[:300], k[:300], strict=True):
        if not g.free[ii, kk]:
            continue
        lo, hi = int(g.run_lo[ii, kk]), int(g.run_hi[ii, kk])
        if hi - lo >= g.n_a:
            continue
        sweep = (kk + np.linspace(lo, hi, 4 * (hi - lo) + 1)) * g.delta
        assert rod_is_free_many(env, np.repeat(g.points[ii][None], len(sweep), 0), sweep,
                                2.0).all()
        assert g.free[ii, np.mod(kk + np.arange(lo, hi + 1), g.n_a)].all()


def test_bad_parameters_raise():
    env = env_of("gallery")
    with pytest.raises(InvalidParameterError):
        surveillance_kernel(env, 1.0, 1.0, 0.5)
    with pytest.raises(InvalidParameterError):
        surveillance_kernel(env, 1.0, 0.5, 1.0, h=0.5, scheme="nearest-ish")
    with pytest.raises(InvalidParameterError):
        build_grid(env, 1.0, -1.0, 90)
    with pytest.raises(InvalidParameterError):
        build_grid(env, 1.0, 0.5, 4)
    with pytest.raises(InvalidParameterError):
        surveillance_kernel(env, 1.0, 0.5, 1.0, h=0.5, directions=5)


@pytest.mark.slow
def test_empty_on_a_map_without_strategy():
    # the rectangle at lss 1 has no strategy (Prop. 1): no kernel, however fast the observer
    env = env_of("rectangle")
    for scheme in ("inner", "outer"):
        k = surveillance_kernel(env, 1.0, 1e-3, 1.0, h=0.06, orientations=72, scheme=scheme)
        assert k.converged and k.kernel_states == 0 and k.free_states > 0
        assert len(k.no_safe_start) == k.grid.n_points


def _compare_with_surviving_cells(env, lss, h, n_a, samples, seed=0):
    """Kernel bins vs surviving cells at grid points more than two cells from every region
    boundary (critical curves and walls); returns (mismatches, compared)."""
    ver = analyze(decompose(env, lss))
    k = surveillance_kernel(env, lss, 1e-3, 1.0, h=h, orientations=n_a)
    g = k.grid
    reg = ver.dec.region_at(g.points)
    ok = np.flatnonzero(reg >= 0)
    bnd = shapely.boundary(np.array([r.polygon for r in ver.dec.regions], dtype=object)[reg[ok]])
    far = ok[shapely.distance(shapely.points(g.points[ok]), bnd) > 2 * h]
    rng = np.random.default_rng(seed)
    bad = total = 0
    for i in rng.choice(far, size=min(samples, len(far)), replace=False):
        bins = np.flatnonzero(g.free[i])
        safe = np.array(ver.is_safe(np.repeat(g.points[i][None], len(bins), 0), g.angles[bins]))
        bad += int((safe != k.kernel[i, bins]).sum())
        total += len(bins)
    return bad, total, ver, k


@pytest.mark.slow
def test_fast_observer_kernel_is_the_surviving_cells_gallery():
    bad, total, ver, k = _compare_with_surviving_cells(env_of("gallery"), 2.0, 0.32, 72, 60)
    assert total > 1000 and bad == 0
    assert ver.strategy_exists and k.kernel_states > 0


@pytest.mark.slow
@pytest.mark.parametrize("name,lss", [("convex_corner", 2.0), ("nonconvex_corner", 1.0),
                                      ("gallery", 1.0), ("convex_corner", 1.0)])
def test_fast_observer_kernel_is_the_surviving_cells(name, lss):
    bad, total, ver, k = _compare_with_surviving_cells(env_of(name), lss, 0.15, 90, 150)
    assert total > 1000 and bad == 0
    assert (k.kernel_states > 0) == ver.strategy_exists


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(4))
def test_fast_observer_kernel_is_the_surviving_cells_random_maps(seed):
    rng = np.random.default_rng(seed)
    w, hgt = rng.uniform(4, 8, 2)
    hx, hy = rng.uniform(1.5, w - 2.5), rng.uniform(1.5, hgt - 2.5)
    hw, hh = rng.uniform(0.5, 1.0, 2)
    env = Environment(boundary=[[0, 0], [w, 0], [w, hgt], [0, hgt]],
                      holes=[[[hx, hy], [hx, hy + hh], [hx + hw, hy + hh], [hx + hw, hy]]],
                      name=f"random{seed}")
    lss = float(rng.uniform(0.6, 1.4))
    bad, total, ver, k = _compare_with_surviving_cells(env, lss, 0.1, 90, 120, seed)
    assert total > 500 and bad == 0
    assert (k.kernel_states > 0) == ver.strategy_exists


@pytest.mark.slow
def test_monotone_in_speed_ratio(room_kernels):
    k3, k6, k9 = room_kernels[0.3], room_kernels[0.6], room_kernels[0.9]
    assert all(k.converged for k in (k3, k6, k9))
    assert not (k6.kernel & ~k3.kernel).any()
    assert not (k9.kernel & ~k6.kernel).any()
    assert k3.kernel_states > k6.kernel_states > 0


@pytest.mark.slow
def test_outer_scheme_contains_inner():
    env = env_of("nonconvex_corner")
    grid = build_grid(env, 1.0, 0.25, 72)
    inner = surveillance_kernel(env, 1.0, 0.6, 1.0, grid=grid, scheme="inner")
    outer = surveillance_kernel(env, 1.0, 0.6, 1.0, grid=grid, scheme="outer")
    assert not (inner.kernel & ~outer.kernel).any()
    assert outer.kernel_states >= inner.kernel_states


@pytest.mark.slow
def test_kernel_is_a_fixed_point(room_kernels):
    """Re-check one iteration at sampled kernel states by a plain loop over the bins."""
    from tether.rates import rate_interval

    k = room_kernels[0.6]
    g = k.grid
    rng = np.random.default_rng(3)
    idx = np.argwhere(k.kernel)
    sample = idx[rng.choice(len(idx), 150, replace=False)]
    for disp, src, dst, c_lo, c_hi in g.continuations(k.directions):
        row = {int(s): m for m, s in enumerate(src)}
        dist = float(np.hypot(*disp))
        tau = dist / k.vt
        for i, b in sample:
            m = row.get(int(i))
            if m is None:
                continue
            lo, hi = rate_interval(disp / dist * k.vt, g.angles[b], k.lss, k.vo)
            reach = [o for o in range(int(c_lo[m, b]), int(c_hi[m, b]) + 1)
                     if tau * lo - 1e-9 <= o * g.delta <= tau * hi + 1e-9]
            assert any(k.kernel[dst[m], (b + o) % g.n_a] for o in reach)


@pytest.mark.slow
def test_continuations_pass_a_reflex_vertex():
    """Passing just below the corner of an obstacle, the free arc pointing back turns by
    ~80° within one step: it must still be carried (a spurious trap otherwise)."""
    env = env_of("convex_corner")
    g = build_grid(env, 1.0, 0.15, 90)
    i = g.point_at(np.array([[-5.025, -5.025]]))[0]
    for disp, src, dst, c_lo, c_hi in g.continuations(8):
        if not np.allclose(disp, [0.15, 0.0]):
            continue
        m = int(np.flatnonzero(src == i)[0])
        b = int(g.bin_at(np.array([math.radians(120)]))[0])  # up-left, the arc turning back
        assert g.free[i, b] and c_lo[m, b] <= c_hi[m, b]
        end = np.mod(b + np.arange(c_lo[m, b], c_hi[m, b] + 1), g.n_a)
        assert g.free[dst[m], end].all()
        assert np.degrees(g.angles[end]).max() > 170


@pytest.mark.slow
def test_lookups_and_margin(room_kernels):
    k = room_kernels[0.6]
    g = k.grid
    rng = np.random.default_rng(2)
    i = rng.integers(0, g.n_points, 500)
    a = rng.uniform(0, 2 * math.pi, 500)
    pts = g.points[i] + rng.uniform(-0.4, 0.4, (500, 2)) * g.h
    inside = k.contains(pts, a)
    assert np.array_equal(inside, k.kernel[i, g.bin_at(a)])
    m = k.margin(pts, a)
    assert np.all((m > 0) == inside)
    assert np.all(np.abs(m) <= math.pi)
    sf = k.safe_fraction()
    assert sf.shape == (g.n_points,) and np.nanmax(sf) <= 1 and np.nanmin(sf) >= 0
    assert not k.contains([[-100.0, -100.0]], 0.0)[0]
    d = k.to_dict()
    for key in ("grid", "states", "free_states", "kernel_states", "iterations", "converged",
                "seconds"):
        assert key in d
    assert d["grid"]["shape"] == list(g.shape)


def test_critical_distance_is_where_the_line_leaves_the_kernel(room_kernels):
    k = room_kernels[0.6]
    out = k.critical_distance((5.0, 0.2), (5.0, 5.0), -math.pi / 2, goal=0.0)
    ls = out["l_star"]
    assert ls is not None and 0 < ls < 4.8
    below = k.contains([[5.0, 0.2 + ls - 2 * k.grid.h]], -math.pi / 2)[0]
    above = k.contains([[5.0, 0.2 + ls + 2 * k.grid.h]], -math.pi / 2)[0]
    assert above and not below
    assert out["L"] <= out["L_g"]


def test_save_and_load(tmp_path, room_kernels):
    k = room_kernels[0.3]
    path = tmp_path / "k.npz"
    k.save(path)
    k2 = load_kernel(path)
    assert np.array_equal(k.kernel, k2.kernel)
    assert k2.grid.shape == k.grid.shape and k2.vt == k.vt and k2.scheme == k.scheme
    assert k2.to_dict()["kernel_states"] == k.kernel_states


def test_kernel_evader_is_a_target_kind():
    assert "kernel-evader" in TARGETS


def _starts(k, inside: bool, n: int, seed: int, margin_cells: float = 2.0):
    """Start states deeper than ``margin_cells`` cells inside (or outside) the kernel, free."""
    d = k.depth[k.grid.ij[:, 1], k.grid.ij[:, 0], :-1]
    m = margin_cells * k.grid.h
    sel = (d > m) if inside else ((d < -m) & k.grid.free)
    idx = np.argwhere(sel)
    rng = np.random.default_rng(seed)
    pick = idx[rng.choice(len(idx), size=min(n, len(idx)), replace=False)]
    return [(*k.grid.points[i], float(k.grid.angles[b])) for i, b in pick]


@pytest.mark.slow
def test_kernel_controller_holds_and_evader_wins_room():
    env = env_of("nonconvex_corner")
    k = surveillance_kernel(env, 1.0, 0.6, 1.0, h=0.1, orientations=180)
    ver = analyze(decompose(env, 1.0))
    w = World(env, 1.0, 0.6, 1.0, decomposition=ver.dec, verdict=ver, extra={"kernel": k})
    failures = []
    for start in _starts(k, True, 3, 0):
        for kind in sorted(set(TARGETS) - {"track", "pedestrian"}):  # replays need a person
            opts = {"waypoints": [[9.5, 0.5], [0.5, 0.5], [0.5, 9.5]]} if kind == "path" else {}
            r = simulate(w, KernelController(), make_target(kind, w, **opts), start,
                         duration=15.0, dt=0.02, seed=1)
            if not r.held:
                failures.append((kind, start, r.reason))
    assert not failures
    for start in _starts(k, False, 5, 1):
        r = simulate(w, KernelController(), KernelEvader(), start, duration=15.0, dt=0.02)
        assert not r.held, start


@pytest.mark.slow
def test_refinement_converges_gallery():
    """Two resolutions (h and n_a refined together) agree on the safe fraction."""
    env = env_of("gallery")
    coarse = surveillance_kernel(env, 1.0, 0.6, 1.0, h=0.32, orientations=90)
    fine = surveillance_kernel(env, 1.0, 0.6, 1.0, h=0.16, orientations=180)
    assert abs(coarse.safe_fraction_total() - fine.safe_fraction_total()) < 0.03
    # and the fine kernel, read at the coarse grid's states, mostly agrees with it
    g = coarse.grid
    idx = np.argwhere(g.free)
    agree = fine.contains(g.points[idx[:, 0]], g.angles[idx[:, 1]]) == coarse.kernel[g.free]
    assert agree.mean() > 0.95


def test_levels_give_the_target_a_winning_move(room_kernels):
    """From a state removed at iteration n, some target move leaves the observer only
    answers removed earlier (level < n): the evader's strategy is well founded."""
    from tether.game.kernel import IN_KERNEL
    from tether.rates import rate_interval

    k = room_kernels[0.6]
    g = k.grid
    lev = k.level
    assert np.all(lev[~g.free] == 0) and np.all(lev[k.kernel] == IN_KERNEL)
    removed = np.argwhere(g.free & ~k.kernel)
    assert np.all((lev[g.free & ~k.kernel] >= 1) & (lev[g.free & ~k.kernel] <= k.iterations))
    rng = np.random.default_rng(4)
    conts = g.continuations(k.directions)
    for i, b in removed[rng.choice(len(removed), 100, replace=False)]:
        n = lev[i, b]
        found = False
        for disp, src, dst, c_lo, c_hi in conts:
            hit = np.flatnonzero(src == i)
            if len(hit) == 0:
                continue
            m = hit[0]
            dist = float(np.hypot(*disp))
            tau = dist / k.vt
            lo, hi = rate_interval(disp / dist * k.vt, g.angles[b], k.lss, k.vo)
            reach = [o for o in range(int(c_lo[m, b]), int(c_hi[m, b]) + 1)
                     if tau * lo - 1e-9 <= o * g.delta <= tau * hi + 1e-9]
            if all(lev[dst[m], (b + o) % g.n_a] < n for o in reach):
                found = True
                break
        assert found, (i, b, n)


@pytest.mark.slow
@pytest.mark.parametrize("scheme", ["inner", "outer"])
def test_sixteen_directions_kernel_is_inside_the_eight_directions_kernel(room_kernels, scheme):
    """``directions=16`` keeps the 8 lattice moves (same steps, same times) and adds the knight
    moves: the target has more options, the operator is stronger, so its greatest fixed point
    is smaller: ``K16 ⊆ K8`` on the same grid, for either scheme (equality is possible: the
    outer scheme on this grid loses nothing)."""
    g = room_kernels[0.6].grid
    k8 = surveillance_kernel(g.env, 1.0, 0.6, 1.0, grid=g, scheme=scheme)
    k16 = surveillance_kernel(g.env, 1.0, 0.6, 1.0, grid=g, scheme=scheme, directions=16)
    assert k16.converged and k16.directions == 16
    assert not (k16.kernel & ~k8.kernel).any()
    # the knight moves refine the target's headings, they do not change the game much
    assert 0.95 * k8.kernel_states < k16.kernel_states <= k8.kernel_states


@pytest.mark.slow
def test_lstar_between_paper_l_and_safe_lg_room():
    """``L*`` on a real escape point (piece of the room's obstacle corner, Fig. 7's map) along
    the worst straight dash: ``L ≤ L*`` for both schemes; the optimistic scheme's ``L* ≤ L_g``
    within the grid's resolution; the conservative scheme's ``L*`` is at least the
    optimistic one's (it may exceed ``L_g``: its rate rounding costs up to a bin per step)."""
    from tether.analysis import escape_table
    from tether.game.lstar import lstar_cases, resolution

    env = env_of("nonconvex_corner")
    table = escape_table(analyze(decompose(env, 1.0)))
    rows = np.flatnonzero(table.piece >= 0)
    row = int(rows[np.argmin(np.hypot(*(table.q[rows] - [1.0, 0.56]).T))])
    grid = build_grid(env, 1.0, 0.1, 180)
    got = {}
    for scheme in ("inner", "outer"):
        k = surveillance_kernel(env, 1.0, 0.6, 1.0, grid=grid, scheme=scheme)
        cases = lstar_cases(k, table, [row])
        assert len(cases) == 3
        tol = resolution(k)
        for c in cases:
            assert c.l_star is not None and c.l_star >= c.L - tol
            assert c.L < c.L_g
        got[scheme] = cases
    for ci, co in zip(got["inner"], got["outer"], strict=True):
        assert co.l_star <= ci.l_star + 1e-9
        assert co.l_star <= co.L_g + co.tol
