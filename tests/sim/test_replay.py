"""Replayed targets: at the track's position at every step (checked against our own
interpolation of the samples), overspeed refused in one line or clipped and reported."""

import json

import numpy as np
import pytest

from tether import Environment
from tether.arcs import rod_is_free
from tether.cli import main
from tether.errors import InvalidParameterError, InvalidTrackError, OutsideFreeSpaceError
from tether.io.tracks import Track, write_track
from tether.sim.controller import FollowController
from tether.sim.protocols import World
from tether.sim.replay import TrackTarget, clip_track, free_rod_angle
from tether.sim.simulate import simulate
from tether.strategies import make_target

HALL = Environment([(0, 0), (10, 0), (10, 6), (0, 6)], [[(4, 2), (6, 2), (6, 4), (4, 4)]])
WORLD = World(HALL, lss=0.8, vt=0.5, vo=2.0)
# irregular sample times, slower than vt=0.5 everywhere, around the hole
WALK = Track([0.0, 0.7, 3.1, 4.0, 9.5, 10.25],
             [(2, 1), (2.3, 1.1), (3.4, 1.2), (3.8, 1.3), (6.4, 1.4), (6.6, 1.5)], "walk")


def _interp(t, times, xy):
    """Our own linear interpolation of samples (held before and after)."""
    return np.column_stack([np.interp(t, times, xy[:, 0]), np.interp(t, times, xy[:, 1])])


@pytest.mark.parametrize("dt, duration", [(0.1, 10.25), (0.13, 11.0), (0.5, 4.3)])
def test_replayed_positions_are_the_tracks_at_every_step(dt, duration):
    target = TrackTarget(WORLD, track=WALK, dt=dt, duration=duration)
    res = simulate(WORLD, FollowController(), target, (2, 1, np.pi), duration=duration, dt=dt)
    assert res.held
    want = _interp(res.trace.t, WALK.t, WALK.xy)
    assert np.abs(res.trace.p - want).max() < 1e-9
    assert res.trace.t[-1] == pytest.approx(duration)


def test_a_track_that_starts_late_starts_at_simulation_time_zero():
    late = WALK.shifted(100.0)
    target = TrackTarget(WORLD, track=late, dt=0.25)
    res = simulate(WORLD, FollowController(), target, (2, 1, np.pi), duration=5.0, dt=0.25)
    want = _interp(res.trace.t, WALK.t, WALK.xy)
    assert np.abs(res.trace.p - want).max() < 1e-9


FAST = Track([0, 1, 2, 3, 4], [(2, 1), (2.2, 1), (3.2, 1), (3.4, 1), (5.4, 1)], "fast")


def test_overspeed_is_refused_in_one_line():
    with pytest.raises(InvalidTrackError) as err:
        TrackTarget(WORLD, track=FAST, dt=0.1)
    msg = str(err.value)
    assert "segment 1 (t=1 s to 2 s) runs at 1 map units/s, faster than vt=0.5" in msg
    assert "2 of 4 segments are" in msg and "\n" not in msg


def test_clipping_replays_at_vt_and_reports_each_segment():
    target = TrackTarget(WORLD, track=FAST, dt=0.1, speed="clip")
    assert [(c["segment"], c["t"]) for c in target.clipped] == [(1, 1.0), (3, 3.0)]
    assert [c["speed"] for c in target.clipped] == pytest.approx([1.0, 2.0])
    assert target.report()["delay"] == pytest.approx(1.0 + 3.0)
    # independently: a fast segment of length L takes L / vt
    times = np.array([0, 1, 1 + 1.0 / 0.5, 1 + 2 + 1, 1 + 2 + 1 + 2.0 / 0.5])
    res = simulate(WORLD, FollowController(), target, (2, 1, np.pi), duration=8.0, dt=0.1)
    assert np.abs(res.trace.p - _interp(res.trace.t, times, FAST.xy)).max() < 1e-9
    chord = np.linalg.norm(np.diff(res.trace.p, axis=0), axis=1) / 0.1
    assert chord.max() <= 0.5 * (1 + 1e-9)


def test_clip_track_leaves_a_slow_track_alone():
    assert clip_track(WALK, 0.5) == (WALK, [])


def test_after_its_last_sample_the_target_stands_still():
    short = Track([0, 1], [(2, 1), (2.4, 1)])
    target = TrackTarget(WORLD, track=short, dt=0.1)
    res = simulate(WORLD, FollowController(), target, (2, 1, np.pi), duration=3.0, dt=0.1)
    assert np.allclose(res.trace.p[10:], [2.4, 1], atol=1e-12)


def test_the_run_must_start_where_the_track_does():
    target = TrackTarget(WORLD, track=WALK, dt=0.1)
    with pytest.raises(InvalidParameterError, match="but the track at"):
        simulate(WORLD, FollowController(), target, (2.5, 1, np.pi), duration=1.0, dt=0.1)


def test_bad_options():
    with pytest.raises(InvalidParameterError, match="needs a track"):
        make_target("track", WORLD, dt=0.1)
    with pytest.raises(InvalidParameterError, match="step dt"):
        make_target("track", WORLD, track=WALK)
    with pytest.raises(InvalidParameterError, match="refuse, clip"):
        make_target("track", WORLD, track=WALK, dt=0.1, speed="fast")


def test_the_chosen_rod_is_free_and_behind():
    a = free_rod_angle(WORLD, (2, 1), heading=(1, 0))
    assert rod_is_free(HALL, (2, 1), a, 0.8)
    assert abs(np.cos(a) + 1) < 0.2  # behind a target walking +x: pointing -x (or close)
    with pytest.raises(OutsideFreeSpaceError, match="no free rod"):
        free_rod_angle(World(HALL, lss=30.0, vt=0.5, vo=2.0), (2, 1))


# ----------------------------------------------------------------------------- the CLI
MAP = Environment([(0, 0), (10, 0), (10, 6), (0, 6)])


@pytest.fixture
def files(tmp_path):
    m = tmp_path / "hall.json"
    m.write_text(json.dumps(MAP.to_dict()))
    walk = tmp_path / "walk.csv"
    write_track(FAST, walk)
    return m, walk


def _run(capsys, *argv):
    rc = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return rc, out, err


def test_cli_refuses_a_fast_track_in_one_line(capsys, files):
    m, walk = files
    rc, out, err = _run(capsys, "simulate", m, "--lss", 0.8, "--vt", 0.5, "--vo", 2,
                        "--target", "track", "--track", walk)
    assert rc == 2 and out == "" and err.count("\n") == 1
    assert f"track {walk}: segment 1" in err and "--track-speed clip" in err


def test_cli_clips_and_reports_in_json(capsys, files):
    m, walk = files
    rc, out, err = _run(capsys, "simulate", m, "--lss", 0.8, "--vt", 0.5, "--vo", 2,
                        "--target", "track", "--track", walk, "--track-speed", "clip",
                        "--controller", "follow", "--dt", 0.1, "--json")
    assert rc == 0, err
    d = json.loads(out)
    assert d["duration"] == pytest.approx(8.0)  # the clipped track's own
    assert [c["segment"] for c in d["track"]["clipped_segments"]] == [1, 3]
    assert d["start"][:2] == [2.0, 1.0]


TRACK = ["--target", "track", "--track", "{walk}", "--track-speed", "clip"]


@pytest.mark.parametrize("extra, words", [
    ([*TRACK, "--start", 3, 1, 0], "--start 3 1 is not the track's first position (2, 1)"),
    ([*TRACK, "--start", 1, 2], "--start takes X Y A"),
    ([*TRACK, "--columns", "a,b"], "--columns takes three names"),
    (["--target", "random", "--topic", "/p", "--start", 2, 1, 0],
     "--topic applies to --target track only"),
    (["--target", "track"], "--target track needs --track FILE"),
    (["--target", "random"], "--target random needs --start X Y A"),
    (["--target", "path", "--speed", 1], "--speed applies to --target pedestrian only"),
])
def test_cli_start_and_option_errors(capsys, files, extra, words):
    m, walk = files
    argv = ["simulate", m, "--lss", 0.8, "--vt", 0.5, "--vo", 2,
            *(str(walk) if a == "{walk}" else a for a in extra)]
    rc, out, err = _run(capsys, *argv)
    assert rc == 2 and words in err and err.count("\n") == 1


def test_cli_pedestrian_walks_one_simulated_person(capsys, files):
    pytest.importorskip("jupedsim")
    from tether.sim.crowd import pedestrian_tracks

    m, _ = files
    rc, out, err = _run(capsys, "simulate", m, "--lss", 0.8, "--vt", 0.5, "--vo", 2,
                        "--target", "pedestrian", "--seed", 4, "--duration", 3, "--dt", 0.05,
                        "--controller", "follow", "--json")
    assert rc == 0, err
    d = json.loads(out)
    (person,) = pedestrian_tracks(MAP, 1, 4, speed=0.5, duration=3.0, dt=0.05)
    assert np.allclose(d["start"][:2], person.xy[0], atol=1e-12)
    assert d["track"]["clipped_segments"] == []


@pytest.mark.slow
def test_a_track_through_a_wall_is_reported_as_a_deviation(capsys, tmp_path):
    m = tmp_path / "hall.json"
    m.write_text(json.dumps(MAP.to_dict()))
    walk = tmp_path / "out.csv"
    write_track(Track([0, 4, 30], [(8, 3), (9.5, 3), (12, 3)]), walk)  # leaves through x = 10
    rc, out, err = _run(capsys, "simulate", m, "--lss", 0.8, "--vt", 0.5, "--vo", 2,
                        "--target", "track", "--track", walk, "--controller", "follow",
                        "--dt", 0.1, "--duration", 14, "--json")
    assert rc == 0, err
    d = json.loads(out)
    assert d["outcome"] == "held"
    # the track is at x = 9.5 + 10·2.5/26 at t = 14; the walls held the target at x < 10
    assert d["track"]["max_deviation"] == pytest.approx(10 * 2.5 / 26 - 0.5, abs=1e-3)
    rc, out, err = _run(capsys, "simulate", m, "--lss", 0.8, "--vt", 0.5, "--vo", 2,
                        "--target", "track", "--track", walk, "--controller", "follow",
                        "--dt", 0.1, "--duration", 14)
    assert "the walls held the target up to" in out


def test_cli_json_deviation_is_zero_inside(capsys, files):
    m, walk = files
    rc, out, _ = _run(capsys, "simulate", m, "--lss", 0.8, "--vt", 0.5, "--vo", 2,
                      "--target", "track", "--track", walk, "--track-speed", "clip",
                      "--controller", "follow", "--dt", 0.1, "--json")
    assert json.loads(out)["track"]["max_deviation"] < 1e-9
