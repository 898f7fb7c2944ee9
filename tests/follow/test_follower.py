"""The follower's loop: commands within vo, re-acquisition round a corner (and the spin-in-place
baseline's failure there), ``lost`` when nothing can be seen, noisy and late observations."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tether.errors import InvalidParameterError
from tether.follow import Follower, Status
from tether.follow.baseline import SpinSearch
from tether.follow.follower import RETAKE_AFTER
from tether.follow.replay import replay


def _follower(env, **kw):
    opts = dict(lss=1.0, vt=0.5, vo=1.0, cell=0.1, rate=10.0)
    opts.update(kw)
    return Follower(env, **opts)


def test_reacquires_round_the_corner(corridor, track):
    """The observer starts far behind; the person turns the corner and leaves view (occluded
    by V4, the corner); the follower searches and sees them again within seconds, while the
    spin-in-place baseline never does."""
    run = replay(corridor, track, _follower(corridor), lss=1.0, vo=1.0, dt=0.1,
                 start=(0.5, 0.5))
    assert run.losses and all(x.cause == "occluded by V4" for x in run.losses)
    assert all(x.back is not None for x in run.losses)
    assert max(run.reacquisitions) < 2.0
    assert "searching" in run.status and run.percent_in_view > 90
    assert run.max_speed_ratio <= 1 + 1e-12 and run.blocked == 0
    base = replay(corridor, track, SpinSearch(1.0, 1.0, rate=10.0), lss=1.0, vo=1.0, dt=0.1,
                  start=(0.5, 0.5))
    assert base.losses[0].back is None and base.percent_in_view < 50
    assert base.status[-1] == "lost"


@pytest.mark.slow
@settings(max_examples=5, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**16), noise=st.sampled_from([0.0, 0.03, 0.1]))
def test_commanded_velocity_never_above_vo(corridor, track, seed, noise):
    f = _follower(corridor, noise=noise, cell=0.2)
    vo = 1.0
    rng = np.random.default_rng(seed)
    o = np.array([0.5, 0.5])
    for t in np.arange(0.0, 12.0, 0.1):
        p = track.position(t)
        obs = None if rng.random() < 0.3 else p + rng.normal(0, noise, 2) * (noise > 0)
        cmd = f.update(t, obs, observer=o)
        assert math.hypot(*cmd.velocity) <= vo * (1 + 1e-12)
        o = o + 0.1 * cmd.velocity if corridor.contains(*(o + 0.1 * cmd.velocity)) else o


def test_lost_before_any_sighting(corridor):
    cmd = _follower(corridor).update(0.0, None)
    assert cmd.status == Status.LOST and "no sighting" in cmd.reason
    assert not cmd.velocity.any()


def test_lost_when_the_whole_set_is_seen_empty(corridor):
    """The person vanishes (walks out of the map through a door the map lacks) in plain view
    of the corner: the follower sees everywhere they could be and says so."""
    f = _follower(corridor)
    f.update(0.0, (5.5, 0.5), observer=(5.5, 1.5))
    cmd = f.update(0.1, None, observer=(5.5, 1.5))
    assert cmd.status == Status.LOST and "seen without the target" in cmd.reason


def test_lost_when_no_pose_can_see_the_set(corridor):
    """A sensor that sees nothing beyond 1 mm: no candidate pose sees any cell."""
    f = _follower(corridor, sensor_range=1e-3)
    f.update(0.0, (1.0, 0.5), observer=(2.0, 0.5))
    cmd = f.update(0.1, None)
    assert cmd.status == Status.LOST and "no reachable observer pose" in cmd.reason


def test_give_up(corridor):
    f = _follower(corridor, give_up=1.0)
    f.update(0.0, (5.5, 3.0), observer=(1.0, 0.5))
    assert f.update(0.5, None).status == Status.SEARCHING
    cmd = f.update(1.6, None)
    assert cmd.status == Status.LOST and "give_up" in cmd.reason
    assert f.update(1.7, (5.5, 3.4)).status == Status.TRACKING  # a sighting resumes


def test_search_heads_to_the_corner_first(corridor):
    """Seen last just round the corner: the goal is the escape pose beside V4 (5, 1)."""
    f = _follower(corridor)
    f.update(0.0, (5.5, 1.6), observer=(4.5, 0.5))
    cmd = f.update(0.1, None, observer=(3.0, 0.5))
    assert cmd.status == Status.SEARCHING
    assert f.escape_vertex == 4 and cmd.view == 1.0
    # the goal sees the whole set (the last sighting round the corner) and is nearer than V4
    assert f.planner.sees(np.array(cmd.pose[:2]), np.array([[5.5, 1.6]]))[0]
    assert math.dist(cmd.pose[:2], (3.0, 0.5)) <= math.dist((5.0, 1.0), (3.0, 0.5)) + 0.2


@pytest.mark.slow
def test_noisy_observations_keep_tracking(corridor, track):
    run = replay(corridor, track, _follower(corridor, noise=0.05), lss=1.0, vo=1.0, dt=0.1,
                 noise=0.05, seed=4)
    assert run.percent_in_view > 95
    assert run.max_speed_ratio <= 1 + 1e-12
    assert run.status.count("tracking") > 0.9 * len(run.status)


def test_outlier_is_gated_then_retaken(corridor):
    f = _follower(corridor, noise=0.02)
    f.update(0.0, (1.0, 0.5), observer=(2.0, 0.5))
    cmd = f.update(0.1, (4.0, 0.5))  # 3 units in 0.1 s: not the person
    assert cmd.status == Status.TRACKING and cmd.reason == "observation rejected by the gate"
    assert cmd.target[0] < 1.2
    for k in range(2, RETAKE_AFTER + 1):
        f.update(0.1 * k, (4.0, 0.5))
    cmd = f.update(0.1 * (RETAKE_AFTER + 1), (4.0, 0.5))  # persistent: taken as the truth
    assert cmd.target[0] == pytest.approx(4.0)


def test_late_and_out_of_order_observations(corridor):
    f = _follower(corridor)
    f.update(0.0, (1.0, 0.5), observer=(2.0, 0.5))
    cmd = f.update(1.0, (1.4, 0.5), stamp=0.8)  # measured 0.2 s ago, moving +x at 0.5
    assert cmd.target[0] == pytest.approx(1.4 + 0.5 * 0.2)
    assert f.t_seen == 0.8
    cmd = f.update(1.1, (1.2, 0.5), stamp=0.7)  # older than what we have: ignored
    assert f.t_seen == 0.8 and cmd.reason == "observation older than the last one, ignored"
    with pytest.raises(InvalidParameterError, match="stamp"):
        f.update(1.2, (1.5, 0.5), stamp=1.3)


@pytest.mark.parametrize(("kw", "message"), [
    (dict(lss=0.0), "lss must be"), (dict(vt=1.0), "vo must exceed vt"),
    (dict(rate=-1.0), "rate must be"), (dict(noise=math.nan), "noise must be"),
    (dict(controller="nope"), "unknown controller"), (dict(controller="paper"), "verdict"),
    (dict(cell=1e-5), "too small"),
])
def test_bad_parameters_one_clear_error(corridor, kw, message):
    with pytest.raises(InvalidParameterError, match=message):
        _follower(corridor, **kw)


def test_time_must_not_go_back(corridor):
    f = _follower(corridor, cell=0.5)
    f.update(1.0, None)
    with pytest.raises(InvalidParameterError, match="time went back"):
        f.update(0.5, None)
    with pytest.raises(InvalidParameterError, match="observation"):
        f.update(2.0, (1.0, 2.0, 3.0))


@pytest.mark.slow
def test_rod_at_lss_while_tracking(corridor, track):
    """Tracking from behind keeps the rod at lss (the follow law) and never pushes the observer
    into a wall; from ahead (the default start, the widest free arc) the person drives the
    observer into the corner's dead end, and it gets out round the corner."""
    run = replay(corridor, track, _follower(corridor), lss=1.0, vo=1.0, dt=0.1,
                 start=(3.0, 0.5))
    assert run.at_rod_length == 100 and run.max_rod_error <= 0.1 + 1e-9
    assert run.blocked == 0 and run.percent_in_view == 100
    ahead = replay(corridor, track, _follower(corridor), lss=1.0, vo=1.0, dt=0.1)
    assert ahead.observer[0][0] > 4.5 and ahead.percent_in_view == 100
    assert ahead.blocked == 0


def test_command_to_dict(corridor):
    f = _follower(corridor, cell=0.5)
    d = f.update(0.0, None).to_dict()
    assert d["status"] == "lost" and d["pose"] == [None, None, None]
