"""The simulator and its monitor, independent of any controller's beliefs."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import interior_points
from hypothesis import given, settings
from hypothesis import strategies as st

from tether.arcs import free_arcs, rod_is_free_many
from tether.errors import InvalidParameterError, OutsideFreeSpaceError
from tether.io import load_map
from tether.rates import rate_interval, step_rate_interval
from tether.sim.controller import FollowController
from tether.sim.local import LocalArcs
from tether.sim.protocols import Command, World
from tether.sim.simulate import save_trace, simulate
from tether.strategies import TARGETS, make_target

EX = Path(__file__).resolve().parents[2] / "src" / "tether" / "examples"


def world(name="gallery", lss=2.0, vt=0.5, vo=1.0):
    return World(load_map(EX / f"{name}.json"), lss, vt, vo)


class Spinner:
    """A deliberately bad controller: spins the rod at a fixed rate, whatever the speed bound."""

    name = "spinner"

    def __init__(self, rate):
        self.rate = rate

    def reset(self, world, p, a):
        self.lss = world.lss

    def step(self, p, v, a, dt):
        return Command(self.rate, np.zeros(2), "spin")


class Still:
    name = "still"

    def reset(self, world, p, a, rng):
        pass

    def velocity(self, t, p, a):
        return np.zeros(2)


def test_monitor_catches_overspeed():
    w = world()
    r = simulate(w, Spinner(5.0), Still(), (2.0, 4.5, 0.0), duration=2.0, dt=0.01)
    assert r.outcome == "lost"
    assert r.lost_at == 0.0
    assert "beyond vo" in r.reason


def test_monitor_catches_rod_through_a_wall():
    # slow enough to respect vo, but it turns the rod into the walls of the gallery corner
    w = world()
    r = simulate(w, Spinner(0.4), Still(), (1.0, 1.0, 0.8), duration=20.0, dt=0.01)
    assert r.outcome == "lost"
    assert r.reason.startswith(("observer pushed into", "rod occluded by"))
    # located inside the step: the rod is free just before and not free just after
    t = r.lost_at
    a_before, a_after = 0.8 + 0.4 * (t - 1e-6), 0.8 + 0.4 * (t + 1e-6)
    ok = rod_is_free_many(w.env, [(1.0, 1.0), (1.0, 1.0)], [a_before, a_after], w.lss)
    assert ok.tolist() == [True, False]


@pytest.mark.slow
def test_follow_against_random_respects_vo_and_keeps_distance():
    w = world()
    r = simulate(w, FollowController(w), make_target("random", w), (2.0, 2.0, 0.5),
                 duration=10.0, dt=0.02, seed=3)
    assert r.monitor.max_speed_ratio <= 1.0 + 1e-9
    tr = r.trace
    assert np.allclose(np.linalg.norm(tr.observer - tr.p, axis=1), w.lss)
    speeds = np.linalg.norm(np.diff(tr.p, axis=0), axis=1) / r.dt
    assert speeds.max() <= w.vt * (1 + 1e-9)
    assert rod_is_free_many(w.env, tr.p, tr.a, w.lss).all() or r.outcome == "lost"
    d = r.to_dict()
    for k in ("outcome", "lost_at", "reason", "mode_time", "monitor"):
        assert k in d
    assert set(d["monitor"]) == {"max_speed_ratio", "min_clearance", "max_distance_error"}
    assert math.isclose(sum(d["mode_time"].values()), (r.lost_at or r.duration), rel_tol=1e-6,
                        abs_tol=r.dt)


def test_bad_starts():
    w = world()
    with pytest.raises(OutsideFreeSpaceError):
        simulate(w, FollowController(w), Still(), (6.0, 5.0, 0.0))  # inside a hole
    with pytest.raises(OutsideFreeSpaceError):
        simulate(w, FollowController(w), Still(), (1.0, 1.0, math.pi + 0.7))  # rod into a wall
    w2 = world(vt=1.0, vo=1.0)
    with pytest.raises(InvalidParameterError):
        simulate(w2, FollowController(w2), Still(), (2.0, 2.0, 0.5))


def test_save_trace_formats(tmp_path):
    w = world()
    r = simulate(w, FollowController(w), make_target("path", w, waypoints=[[14, 2], [14, 5]]),
                 (2.0, 2.0, 0.5), duration=3.0, dt=0.05)
    for ext in ("json", "csv", "npz"):
        save_trace(r, tmp_path / f"t.{ext}")
    d = json.loads((tmp_path / "t.json").read_text())
    assert len(d["trace"]["t"]) == len(r.trace)
    rows = (tmp_path / "t.csv").read_text().splitlines()
    assert len(rows) == len(r.trace) + 1
    z = np.load(tmp_path / "t.npz")
    assert np.allclose(z["p"], r.trace.p)
    with pytest.raises(InvalidParameterError):
        save_trace(r, tmp_path / "t.txt")


def test_path_target_constant_speed():
    w = world()
    r = simulate(w, FollowController(w), make_target("path", w, waypoints=[[10, 2]]),
                 (2.0, 2.0, 0.5), duration=20.0, dt=0.05)
    speeds = np.linalg.norm(np.diff(r.trace.p, axis=0), axis=1) / r.dt
    assert np.allclose(speeds[:100], w.vt)
    assert np.allclose(r.trace.p[-1], [10, 2])


@pytest.mark.slow
@pytest.mark.parametrize("kind", sorted(TARGETS))
def test_targets_bounded_speed_and_seeded(kind):
    w = world()
    opts = {"waypoints": [[14, 2], [14, 10]]} if kind == "path" else {}
    if kind == "track":  # a replay: from the start, along the wall's row at half vt
        from tether.io.tracks import Track

        opts = {"track": Track([0.0, 2.0, 4.0], [(2.0, 2.0), (2.5, 2.0), (2.5, 2.5)]),
                "dt": 0.05}
    start = (2.0, 2.0, 0.5)
    if kind == "pedestrian":  # a simulated person starts where the crowd model puts them
        pytest.importorskip("jupedsim")
        from tether.sim.replay import free_rod_angle

        opts = {"dt": 0.05, "seed": 3}
        p0 = make_target(kind, w, **opts).start
        start = (p0[0], p0[1], free_rod_angle(w, p0))
    runs = [simulate(w, FollowController(w), make_target(kind, w, **opts), start,
                     duration=4.0, dt=0.05, seed=7) for _ in range(2)]
    assert np.array_equal(runs[0].trace.p, runs[1].trace.p)
    speeds = np.linalg.norm(np.diff(runs[0].trace.p, axis=0), axis=1) / 0.05
    assert speeds.max() <= w.vt * (1 + 1e-9)


@settings(max_examples=60, deadline=None)
@given(st.floats(-3, 3), st.floats(0, 2 * math.pi), st.floats(0.0, 0.99),
       st.sampled_from([0.01, 0.05, 0.2]))
def test_step_rate_interval_chord(psi, a, ratio, dt):
    lss, vo = 2.0, 1.0
    v = ratio * vo * np.array([math.cos(psi), math.sin(psi)])
    lo, hi = step_rate_interval(v, a, lss, vo, dt)
    assert lo <= 0 <= hi
    for r in (lo, hi, 0.5 * (lo + hi)):
        d = v * dt + lss * (np.array([math.cos(a + r * dt), math.sin(a + r * dt)])
                            - [math.cos(a), math.sin(a)])
        assert np.linalg.norm(d) <= vo * dt * (1 + 1e-9)
    # tends to Ω as dt -> 0
    lo0, hi0 = step_rate_interval(v, a, lss, vo, 1e-7)
    L0, H0 = rate_interval(v, a, lss, vo)
    assert abs(lo0 - L0) < 1e-5 and abs(hi0 - H0) < 1e-5


@pytest.mark.parametrize("name", ["gallery", "convex_corner", "nonconvex_corner"])
def test_local_arcs_match_free_arcs(name):
    env = load_map(EX / f"{name}.json")
    loc = LocalArcs(env, 2.0)
    pts = interior_points(env, 120, seed=2)
    ang = np.random.default_rng(2).uniform(0, 2 * math.pi, len(pts))
    ref = rod_is_free_many(env, pts, ang, 2.0)
    for p, t, free in zip(pts, ang, ref, strict=True):
        e = loc.ends(float(p[0]), float(p[1]), float(t))
        assert e.free == bool(free)
        if free:
            fa = free_arcs(env, p, 2.0)
            if fa.full:
                assert e.ccw_gap == math.inf
                continue
            arc = next(x for x in fa.arcs if x.contains(t))
            assert abs((arc.end - t) % (2 * math.pi) - e.ccw_gap) < 1e-9
            assert (arc.start_feature, arc.end_feature) == (e.cw_feature, e.ccw_feature)
