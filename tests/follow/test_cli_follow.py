"""``tether follow``: the report, its JSON, the comparison with the spin baseline, figures, and
one-line errors (exit 2)."""

from __future__ import annotations

import json

import pytest

from tether.cli import main
from tether.io import save_map
from tether.io.tracks import write_track


@pytest.fixture
def files(tmp_path, corridor, track):
    m, t = tmp_path / "corridor.json", tmp_path / "person.csv"
    save_map(corridor, m)
    write_track(track, t)
    return str(m), str(t)


BASE = ["--lss", "1", "--vt", "0.5", "--vo", "1", "--start", "0.5", "0.5", "--cell", "0.1"]


@pytest.mark.slow
def test_json_report_with_baseline(capsys, files):
    m, t = files
    assert main(["follow", m, "--track", t, *BASE, "--baseline", "spin", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    f, b = out["follower"], out["baseline"]
    assert out["track"] == "person" and out["segments_faster_than_vt"] == 0
    for run in (f, b):
        assert set(run) >= {"time_in_view", "percent_in_view", "losses", "loss_causes",
                            "loss_events", "reacquisition_times", "monitor"}
        assert run["monitor"]["max_speed_ratio"] <= 1 + 1e-12
    assert f["losses"] >= 1 and f["never_reacquired"] == 0
    assert f["loss_causes"] == {"occluded by V4": f["losses"]}
    assert b["never_reacquired"] == 1 and b["percent_in_view"] < f["percent_in_view"]


def test_text_report(capsys, files):
    m, t = files
    assert main(["follow", m, "--track", t, *BASE, "--range", "3", "--noise", "0.02",
                 "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["range"] == 3.0 and d["follower"]["monitor"]["max_speed_ratio"] <= 1 + 1e-12
    assert "baseline" not in d
    assert main(["follow", m, "--track", t, *BASE, "--range", "3", "--noise", "0.02"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("follow 'person' in 'corridor'")
    assert "in view" in out and "back in view after (s):" in out and "monitor:" in out


def test_faster_track_is_reported(capsys, files):
    m, t = files
    assert main(["follow", m, "--track", t, "--lss", "1", "--vt", "0.2", "--vo", "1",
                 "--cell", "0.2"]) == 0
    assert "faster than vt" in capsys.readouterr().out


@pytest.mark.parametrize(("extra", "message"), [
    (["--vo", "0.4"], "vo must exceed vt"),
    (["--plot", "/no/such/folder/f.png"], "does not exist"),
    (["--noise", "-1"], "out of range"),
    (["--start", "9", "9"], "--start (9, 9) is not in the map's free space"),
])
def test_bad_input_one_line(capsys, files, extra, message):
    m, t = files
    argv = ["follow", m, "--track", t, *BASE]
    if extra[0] in ("--vo", "--start"):
        i = argv.index(extra[0])
        argv[i + 1:i + len(extra)] = extra[1:]
    else:
        argv += extra
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and message in err


def test_track_outside_the_map(capsys, tmp_path, files):
    m, _ = files
    bad = tmp_path / "far.csv"
    bad.write_text("t,x,y\n0,50,50\n1,51,50\n")
    assert main(["follow", m, "--track", str(bad), *BASE]) == 2
    assert "outside the map's free space" in capsys.readouterr().err


def test_missing_track_file(capsys, files):
    m, _ = files
    assert main(["follow", m, "--track", "/no/such/track.csv", *BASE]) == 2
    assert capsys.readouterr().err.startswith("tether: error:")


@pytest.mark.slow
def test_plot(tmp_path, files):
    m, _ = files
    short = tmp_path / "short.csv"
    short.write_text("t,x,y\n0,4.5,0.5\n2,5.5,0.5\n5,5.5,2\n")  # round the corner, 5 s
    png = tmp_path / "f.png"
    assert main(["follow", m, "--track", str(short), *BASE, "--baseline", "spin", "--plot",
                 str(png)]) == 0
    assert png.stat().st_size > 10_000


@pytest.mark.slow
def test_animation(tmp_path, corridor, track):
    from tether.follow import Follower
    from tether.follow.replay import replay
    from tether.plot.follow import animate_follow

    run = replay(corridor, track, Follower(corridor, 1.0, 0.5, 1.0, cell=0.2), lss=1.0, vo=1.0,
                 start=(0.5, 0.5))
    gif = animate_follow(run, corridor, tmp_path / "f.gif", max_frames=6)
    assert gif.stat().st_size > 10_000
    with pytest.raises(Exception, match="animations are"):
        animate_follow(run, corridor, tmp_path / "f.avi")
