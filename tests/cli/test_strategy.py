"""CLI of the strategy layer: JSON keys and exit codes."""

import json

import pytest

from tether.cli import main
from tether.examples import path as example_path

NC = str(example_path("nonconvex_corner"))
GAL = str(example_path("gallery"))


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.slow
def test_assess_json(capsys, tmp_path):
    code, out, _ = run(capsys, "assess", NC, "--lss", "2", "--vt", "0.5", "--vo", "1",
                       "--at", "5", "1", "1.57", "--json", "--plot", str(tmp_path / "a.png"))
    assert code == 0
    d = json.loads(out)
    for k in ("safe", "cell", "reasons", "escape_points"):
        assert k in d
    assert d["safe"] is True and d["cell"] == "(R5,E1,E1)"
    assert (tmp_path / "a.png").stat().st_size > 0


def test_assess_text(capsys):
    code, out, _ = run(capsys, "assess", NC, "--lss", "2", "--vt", "0.5", "--vo", "1",
                       "--at", "5", "1", "1.57")
    assert code == 0 and "SAFE" in out


@pytest.mark.slow
def test_simulate_json_and_files(capsys, tmp_path):
    code, out, _ = run(capsys, "simulate", NC, "--lss", "2", "--vt", "0.5", "--vo", "1",
                       "--start", "5", "1", "1.57", "--target", "random", "--duration", "2",
                       "--json", "--trace", str(tmp_path / "t.csv"),
                       "--plot", str(tmp_path / "p.png"))
    assert code == 0
    d = json.loads(out)
    assert d["outcome"] in ("held", "lost")
    for k in ("outcome", "lost_at", "reason", "mode_time", "monitor"):
        assert k in d
    assert set(d["monitor"]) >= {"max_speed_ratio", "min_clearance", "max_distance_error"}
    assert (tmp_path / "t.csv").exists() and (tmp_path / "p.png").exists()


def test_simulate_path_file(capsys, tmp_path):
    wp = tmp_path / "w.txt"
    wp.write_text("# waypoints\n8 1\n8 5\n")
    code, out, _ = run(capsys, "simulate", NC, "--lss", "2", "--vt", "0.5", "--vo", "1",
                       "--start", "5", "1", "1.57", "--target", "path", "--path", str(wp),
                       "--duration", "3")
    assert code == 0 and "path vs paper" in out


@pytest.mark.slow
def test_simulate_lost_exits_zero(capsys):
    # the follow controller cannot pivot about a reflex vertex closer than Lss·vt/(vo+vt)
    code, out, _ = run(capsys, "simulate", GAL, "--lss", "2", "--vt", "0.9", "--vo", "1",
                       "--start", "2", "2.5", "0.5", "--target", "random", "--seed", "1",
                       "--controller", "follow", "--duration", "30", "--json")
    assert code == 0
    assert json.loads(out)["outcome"] in ("held", "lost")


@pytest.mark.parametrize("argv, words", [
    (["--start", "20", "1", "0"], "not inside the free space"),
    (["--start", "5", "0.5", "-1.57"], "not free"),
    (["--start", "5", "1", "1.57", "--vt", "1"], "vo must exceed vt"),
    (["--start", "5", "1", "1.57", "--target", "nope"], "unknown target kind"),
    (["--start", "5", "1", "1.57", "--controller", "nope"], "unknown controller"),
    (["--start", "5", "1", "1.57", "--animate", "x.avi"], "x.avi"),
])
def test_simulate_bad_input(capsys, argv, words):
    base = ["simulate", NC, "--lss", "2", "--vo", "1", "--duration", "1"]
    if "--vt" not in argv:
        base += ["--vt", "0.5"]
    code, _, err = run(capsys, *base, *argv)
    assert code == 2
    assert err.startswith("tether: error:") and words in err


def test_assess_rejects_a_target_outside_the_free_space(capsys):
    code, out, err = run(capsys, "assess", NC, "--lss", "2", "--vt", "0.5", "--vo", "1",
                         "--at", "-50", "1", "0")
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "(-50, 1) is outside the free space" in err


def test_assess_calls_a_blocked_rod_unsafe(capsys):
    code, out, _ = run(capsys, "assess", NC, "--lss", "2", "--vt", "0.5", "--vo", "1",
                       "--at", "5", "0.5", "-1.57", "--json")
    d = json.loads(out)
    assert code == 0 and d["safe"] is False and d["rod_free"] is False
