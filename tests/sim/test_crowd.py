"""Simulated people (jupedsim): inside the free space, never above the desired speed, seeded."""

import sys

import numpy as np
import pytest
import shapely

from tether import Environment
from tether.errors import InvalidParameterError
from tether.examples import load as load_example
from tether.sim.crowd import RADIUS, SPEED_TOL, CrowdUnavailableError, pedestrian_tracks

jupedsim = pytest.importorskip("jupedsim")

GALLERY = load_example("gallery")
ROOM = Environment([(0, 0), (6, 0), (6, 4), (0, 4)],
                   [[(2.5, 1.5), (3.5, 1.5), (3.5, 2.5), (2.5, 2.5)]])


@pytest.fixture(scope="module")
def people():
    return pedestrian_tracks(GALLERY, 4, seed=11, speed=0.29, duration=40.0, dt=0.1)

def test_every_sample_inside_the_free_space(people):
    env = GALLERY
    for tr in people:
        inside = shapely.contains_xy(env.polygon, tr.xy[:, 0], tr.xy[:, 1])
        assert inside.all(), f"{tr.name} leaves the free space at t={tr.t[np.argmin(inside)]}"
        # and keeps (nearly) a body's radius off the walls
        gap = shapely.distance(env.polygon.boundary, shapely.points(tr.xy))
        assert gap.min() > 0.5 * RADIUS

def test_speed_never_above_the_desired_speed(people):
    for tr in people:
        assert tr.max_speed <= 0.29 * (1 + SPEED_TOL)
        assert tr.max_speed > 0.2  # they do walk
        assert np.allclose(tr.t, np.arange(401) * 0.1)

def test_same_seed_same_tracks_other_seed_other_tracks(people):
    again = pedestrian_tracks(GALLERY, 4, seed=11, speed=0.29, duration=40.0, dt=0.1)
    assert all(np.array_equal(a.xy, b.xy) for a, b in zip(people, again, strict=True))
    other = pedestrian_tracks(GALLERY, 4, seed=12, speed=0.29, duration=40.0, dt=0.1)
    assert not np.allclose(people[0].xy, other[0].xy)

def test_people_keep_apart(people):
    xy = np.stack([tr.xy for tr in people])  # (people, samples, 2)
    d = np.linalg.norm(xy[:, None] - xy[None, :], axis=-1)
    d[np.arange(len(people)), np.arange(len(people))] = np.inf
    assert d.min() > RADIUS  # bodies (radius 0.2) may touch, centres never meet

def test_given_goals_are_visited_in_turn():
    goals = [(1.0, 1.0), (5.0, 3.0)]
    (tr,) = pedestrian_tracks(ROOM, 1, seed=0, speed=1.0, duration=30.0, goals=goals)
    for g in goals:
        assert np.hypot(*(tr.xy - g).T).min() < 2 * RADIUS + 0.05
    assert tr.max_speed <= 1.0 * (1 + SPEED_TOL)

def test_default_speed_is_weidmanns_in_map_units():
    (tr,) = pedestrian_tracks(ROOM, 1, seed=0, duration=3.0, metres_per_unit=2.0)
    assert tr.meta["speed"] == pytest.approx(1.34 / 2)
    assert tr.max_speed <= 1.34 / 2 * (1 + SPEED_TOL)

@pytest.mark.parametrize("kwargs, words", [
    ({"count": 0}, "count"),
    ({"duration": -1.0}, "duration"),
    ({"speed": float("nan")}, "speed"),
    ({"goals": [(2.9, 2.0)]}, "goal 0"),
    ({"goals": [[1, 2, 3]]}, "goals"),
])
def test_bad_parameters_one_line(kwargs, words):
    args = {"count": 1, "seed": 0, **kwargs}
    with pytest.raises(InvalidParameterError, match=words) as err:
        pedestrian_tracks(ROOM, args.pop("count"), args.pop("seed"), **args)
    assert "\n" not in str(err.value)

def test_too_narrow_a_map_is_refused():
    with pytest.raises(InvalidParameterError, match="no walkable area"):
        pedestrian_tracks(Environment([(0, 0), (0.3, 0), (0.3, 5), (0, 5)]), 1, 0)

def test_without_jupedsim_one_line(monkeypatch):
    monkeypatch.setitem(sys.modules, "jupedsim", None)
    with pytest.raises(CrowdUnavailableError, match=r"pip install tether\[crowd\]"):
        pedestrian_tracks(ROOM, 1, 0)


# ----------------------------------------------------------------------------- tether tracks
def _tracks(capsys, *argv):
    from tether.cli import main

    rc = main(["tracks", *(str(a) for a in argv)])
    out, err = capsys.readouterr()
    return rc, out, err


def test_cli_writes_the_tracks_it_lists(capsys, tmp_path):
    import json

    from tether.examples import path as example_path
    from tether.io.tracks import read_track

    out_dir = tmp_path / "new" / "people"
    rc, out, err = _tracks(capsys, example_path("gallery"), "--count", 3, "--seed", 5,
                           "--speed", 0.29, "--duration", 4, "--dt", 0.1, "--out", out_dir,
                           "--format", "json", "--json")
    assert rc == 0, err
    listed = json.loads(out)["files"]
    assert sorted(p.name for p in out_dir.iterdir()) == [
        "track_000.json", "track_001.json", "track_002.json"]
    direct = pedestrian_tracks(GALLERY, 3, seed=5, speed=0.29, duration=4.0, dt=0.1)
    for row, person in zip(listed, direct, strict=True):
        back = read_track(row["path"])
        assert np.array_equal(back.xy, person.xy) and np.array_equal(back.t, person.t)


@pytest.mark.parametrize("argv, words", [
    (["--count", 0, "--out", "{tmp}/x"], "--count: 0 is out of range"),
    (["--count", 1, "--out", "{file}/x"], "is a file, not a folder"),
    (["--count", 1, "--out", "{tmp}/x", "--speed", -1], "--speed"),
])
def test_cli_errors_one_line(capsys, tmp_path, argv, words):
    from tether.examples import path as example_path

    (tmp_path / "f.txt").write_text("")
    argv = [str(a).replace("{tmp}", str(tmp_path)).replace("{file}", str(tmp_path / "f.txt"))
            for a in argv]
    rc, out, err = _tracks(capsys, example_path("gallery"), *argv)
    assert rc == 2 and words in err and err.count("\n") == 1 and out == ""
    assert not (tmp_path / "x").exists()


def test_cli_without_jupedsim_one_line(capsys, tmp_path, monkeypatch):
    from tether.examples import path as example_path

    monkeypatch.setitem(sys.modules, "jupedsim", None)
    rc, out, err = _tracks(capsys, example_path("gallery"), "--count", 1, "--out",
                           tmp_path / "x")
    assert rc == 2 and "need `pip install tether[crowd]`" in err and err.count("\n") == 1
