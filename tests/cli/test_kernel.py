"""``tether kernel``: JSON keys of the issue, --at, --save/--plot, exit 2 on bad input."""

from __future__ import annotations

import json

import pytest

from tether.cli import main
from tether.examples import path as example_path
from tether.game import load_kernel

BASE = ["kernel", str(example_path("gallery")), "--lss", "1", "--vt", "0.6", "--vo", "1",
        "--h", "0.5", "--orientations", "36"]


@pytest.mark.slow
def test_kernel_json_and_at(capsys, tmp_path):
    npz = tmp_path / "k.npz"
    png = tmp_path / "k.png"
    assert main([*BASE, "--json", "--at", "3", "2", "1.0", "--save", str(npz),
                 "--plot", str(png)]) == 0
    out = json.loads(capsys.readouterr().out)
    for key in ("states", "free_states", "kernel_states", "iterations", "converged", "seconds"):
        assert key in out
    assert set(out["grid"]) >= {"h", "orientations", "shape"}
    assert out["grid"]["orientations"] == 36
    assert out["at"]["in_kernel"] is True and out["at"]["margin"] > 0
    assert load_kernel(npz).kernel_states == out["kernel_states"]
    assert png.stat().st_size > 0


def test_kernel_text(capsys):
    assert main(BASE) == 0
    assert "kernel:" in capsys.readouterr().out


@pytest.mark.parametrize("extra,message", [
    (["--vt", "2"], "vo must exceed vt"),
    (["--h", "-1"], "h must be"),
    (["--save", "k.txt"], ".npz"),
    (["--plot", "k.xyz"], "extension"),
])
def test_kernel_bad_input_exit_2(capsys, extra, message, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main([*BASE, *extra]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


# ---- the kernel controller in ``tether simulate`` ------------------------------------------
SIM = ["simulate", str(example_path("gallery")), "--lss", "1", "--vt", "0.6", "--vo", "1",
       "--start", "2", "2.5", "0.5", "--controller", "kernel", "--duration", "2", "--json"]


@pytest.mark.slow
def test_simulate_kernel_controller_with_saved_kernel(capsys, tmp_path):
    npz = tmp_path / "k.npz"
    assert main([*BASE, "--save", str(npz)]) == 0
    capsys.readouterr()
    assert main([*SIM, "--kernel", str(npz), "--target", "kernel-evader"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["controller"] == "kernel" and out["outcome"] == "held"
    assert out["monitor"]["max_speed_ratio"] <= 1.0 + 1e-9


@pytest.mark.slow
def test_simulate_kernel_controller_on_demand(capsys):
    assert main(SIM) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["controller"] == "kernel"


@pytest.mark.parametrize("extra,message", [
    (["--kernel", "missing.npz"], "no such file"),
    (["--controller", "paper", "--kernel", "k.npz"], "applies to"),
])
def test_simulate_kernel_bad_input(capsys, extra, message):
    assert main([*SIM, *extra]) == 2
    assert message in capsys.readouterr().err


def test_simulate_kernel_speed_mismatch(capsys, tmp_path):
    npz = tmp_path / "k.npz"
    assert main([*BASE, "--save", str(npz)]) == 0
    capsys.readouterr()
    args = [*SIM, "--kernel", str(npz)]
    args[args.index("--vt") + 1] = "0.5"
    assert main(args) == 2
    assert "vt=0.6" in capsys.readouterr().err


ROOM = ["kernel", str(example_path("nonconvex_corner")), "--lss", "1", "--vt", "0.3", "--vo",
        "1", "--h", "0.5", "--certified"]


@pytest.mark.slow
def test_certified_json_at_save_and_simulate(capsys, tmp_path):
    """``--certified --at --json --save``: the answer at a state, the file re-certified on
    reading by ``simulate --controller certified --kernel``, which holds against ``wall``."""
    npz = tmp_path / "room.npz"
    png = tmp_path / "room.png"
    assert main([*ROOM, "--json", "--at", "5", "5", "0", "--save", str(npz), "--plot",
                 str(png)]) == 0
    assert png.stat().st_size > 0
    out = json.loads(capsys.readouterr().out)
    assert out["certified"] is True and out["scheme"] == "certified"
    assert out["failing_triangles"] == {"free": 0, "open": 0, "lo": 0, "hi": 0}
    assert 0.5 < out["safe_fraction"] < 1.0
    assert out["at"]["certified"] == "safe" and out["at"]["margin"] > 0
    band = out["band"]  # the lattice's free states split three ways, the certified ones first
    assert (band["certified_states"] + band["undecided_states"] + band["unsafe_states"]
            == band["free_states"] > 0)
    assert band["contradictions"] == 0 and 0 < band["share"] < 0.5
    assert 0 < band["reach_95"] <= band["reach"] < 3.0
    sim = ["simulate", str(example_path("nonconvex_corner")), "--lss", "1", "--vt", "0.3",
           "--vo", "1", "--controller", "certified", "--kernel", str(npz), "--target",
           "wall", "--start", "5", "5", "0", "--duration", "5", "--json"]
    assert main(sim) == 0
    assert json.loads(capsys.readouterr().out)["outcome"] == "held"
    sim[5] = "0.6"  # a field certified at vt 0.3 is refused for a run at 0.6
    assert main(sim) == 2
    assert "vt" in capsys.readouterr().err


@pytest.mark.parametrize("extra,message", [
    (["--plot", "k.xyz"], "extension"),
    (["--scheme", "outer"], "--certified has none"),
    (["--h", "nan"], "h must be"),
])
def test_certified_bad_input_exit_2(capsys, extra, message, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main([*ROOM, *extra]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


@pytest.mark.slow
def test_assess_certified_answer_first(capsys):
    """``assess --certified``: the certified answer is the first line (and the first JSON
    key), the paper's conditions follow, labelled as the paper's."""
    base = ["assess", str(example_path("nonconvex_corner")), "--lss", "1", "--vt", "0.3",
            "--vo", "1", "--certified"]
    assert main([*base, "--at", "5", "5", "0"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("certified: SAFE")
    assert lines[1].startswith("paper's conditions (Props. 2-3): ")
    assert main([*base, "--at", "0.5", "5", "3.14159", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert list(out)[0] == "certified"
    assert out["certified"]["answer"] == "unsafe" and out["certified"]["field_certified"]


@pytest.mark.slow
def test_certified_delay_json_and_text(capsys):
    """``--certified --delay``: the distance band in the text (a map whose search stops at
    once: no field, nothing claimed)."""
    corner = ["kernel", str(example_path("convex_corner")), "--lss", "1", "--vt", "0.3", "--vo",
              "1", "--h", "1", "--certified", "--delay", "0.5"]
    assert main(corner) == 0
    out = capsys.readouterr().out
    assert "within lss +/- 0.15 (0.85 to 1.15)" in out and "NOT certified" in out


@pytest.mark.parametrize("extra, message", [
    (["--delay", "0.5"], "--delay applies to --certified only"),
    (["--certified", "--delay", "-1"], "delay must be a finite number >= 0"),
    (["--certified", "--delay", "nan"], "delay must be a finite number >= 0"),
    (["--certified", "--delay", "5"], "too long"),
])
def test_certified_delay_bad_input(capsys, extra, message):
    assert main([*BASE, *extra]) == 2
    assert message in capsys.readouterr().err


@pytest.mark.slow
def test_certified_refine_json_and_progress(capsys, tmp_path):
    """``--certified --refine --max-vertices --json``: one record per round in ``refine``
    (round 0 the uniform mesh; round 1 stopped by the vertex budget), each round's band on
    stderr, and the band of the field kept."""
    room = tmp_path / "room6.json"
    room.write_text(json.dumps({"name": "room6", "boundary": [[0, 0], [6, 0], [6, 6],
                                                              [0, 6]]}))
    args = ["kernel", str(room), "--lss", "1", "--vt", "0.3", "--vo", "1", "--certified",
            "--h", "0.5", "--refine", "2", "--max-vertices", "200", "--json"]
    assert main(args) == 0
    cap = capsys.readouterr()
    out = json.loads(cap.out)
    assert out["certified"] is True
    rounds = out["refine"]
    assert rounds[0]["round"] == 0 and rounds[0]["vertices"] == out["mesh"]["vertices"]
    assert rounds[1]["stopped"] == "max_vertices" and rounds[1]["would_have"] > 200
    assert rounds[0]["undecided_share"] == pytest.approx(out["band"]["share"])
    assert "refine round 0:" in cap.err and "--max-vertices" in cap.err


@pytest.mark.parametrize("extra, message", [
    (["--refine", "2"], "apply to --certified only"),
    (["--band-width", "0.3"], "apply to --certified only"),
    (["--certified", "--band-width", "-1"], "--band-width must be a finite number >= 0"),
    (["--certified", "--refine", "-1"], "--refine"),
])
def test_refine_bad_input(capsys, extra, message):
    assert main([*BASE, *extra]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
