"""The ``tether`` command: output shapes, exit codes, one-line errors."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import pytest

from tether.cli import main
from tether.examples import path as example_path


def run_json(capsys, argv):
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


def test_info_json(capsys):
    info = run_json(capsys, ["info", str(example_path("gallery")), "--json"])
    assert info["vertices"] == 14 and info["holes"] == 2
    assert info["area"] == pytest.approx(16 * 9 + 8 * 3 - 2 * 2 - 1 * 4)
    assert "V4" in info["reflex_vertices"]


def test_arcs_json_shape(capsys):
    out = run_json(capsys, ["arcs", str(example_path("gallery")), "--lss", "2", "--at", "9",
                            "1.5", "--json"])
    assert out["point"] == [9.0, 1.5] and out["lss"] == 2.0 and out["full"] is False
    (arc,) = out["arcs"]
    assert arc["start_feature"] == "E0" and arc["end_feature"] == "E0"
    # facing the floor at height 1.5 with a rod of 2: blocked span is 2*acos(1.5/2) wide
    blocked = 2 * math.acos(0.75)
    assert (arc["end"] - arc["start"]) % (2 * math.pi) == pytest.approx(2 * math.pi - blocked)


@pytest.mark.parametrize(("argv", "message"), [
    (["arcs", "GALLERY", "--lss", "0", "--at", "1", "1"], "lss must be a finite length > 0"),
    (["arcs", "GALLERY", "--lss", "nan", "--at", "1", "1"], "lss must be a finite length > 0"),
    (["arcs", "GALLERY", "--lss", "2", "--at", "6", "5"], "outside the free space"),
    (["arcs", "GALLERY", "--lss", "2", "--at", "0", "3"], "on the boundary"),
])
def test_user_errors_exit_2_with_one_line(capsys, argv, message):
    argv = [str(example_path("gallery")) if a == "GALLERY" else a for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("tether: error: ") and err.count("\n") == 1 and message in err


@pytest.mark.slow
def test_demo_runs(capsys):
    assert main(["demo"]) == 0
    out = capsys.readouterr().out
    assert "gallery" in out and "free arc" in out


@pytest.mark.slow
def test_console_script_usage_error_is_status_2():
    proc = subprocess.run([sys.executable, "-m", "tether.cli", "arcs"], capture_output=True,
                          text=True)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr


def test_bound_json(capsys):
    out = run_json(capsys, ["bound", "--vt", "1", "--vo", "2", "--lss", "1", "--from", "0",
                            "--to", str(math.pi / 2), "--json"])
    assert set(out) == {"rotation_time", "distance_bound", "worst_case_time",
                        "worst_case_distance"}
    assert out["rotation_time"] == pytest.approx(1.31164147289295, abs=1e-12)
    assert out["worst_case_time"] == pytest.approx(math.pi / 2)
    assert out["distance_bound"] <= out["worst_case_distance"]


@pytest.mark.parametrize("argv", [
    ["bound", "--vt", "2", "--vo", "2", "--lss", "1", "--from", "0", "--to", "1"],
    ["bound", "--vt", "1", "--vo", "2", "--lss", "0", "--from", "0", "--to", "1"],
    ["bound", "--vt", "1", "--vo", "2", "--lss", "1", "--from", "nan", "--to", "1"],
    ["plot-motion", "rotation", "--vt", "3", "--out", "never.png"],
])
def test_bound_errors(capsys, argv, tmp_path):
    assert main(argv) == 2
    assert capsys.readouterr().err.count("\n") == 1
    assert not (tmp_path / "never.png").exists()


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["tractrix", "rotation", "wall", "vertex"])
def test_plot_motion_writes_a_png(tmp_path, kind):
    out = tmp_path / f"{kind}.png"
    assert main(["plot-motion", kind, "--out", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(tmp_path.glob("*.part*"))


@pytest.mark.slow
def test_bound_plot(tmp_path, capsys):
    out = tmp_path / "b.png"
    assert main(["bound", "--vt", "1", "--vo", "2", "--lss", "1", "--from", "0", "--to", "2",
                 "--plot", str(out)]) == 0
    assert out.stat().st_size > 1000


@pytest.mark.slow
def test_decompose_json_shape(capsys, tmp_path):
    out = tmp_path / "d.png"
    data = run_json(capsys, ["decompose", str(example_path("rectangle")), "--lss", "1",
                             "--json", "--plot", str(out), "--by-type", "--geometry"])
    assert data["counts"] == {"regions": 19, "cells": 32, "pieces": len(data["pieces"])}
    assert data["regions"][0]["polygon"].startswith("POLYGON")
    r = data["regions"][0]
    assert set(r) >= {"id", "area", "point", "cells"}
    c = data["cells"][0]
    assert set(c) >= {"id", "region", "start_feature", "end_feature"}
    assert {k["type"] for k in data["curves"]} == {"A", "B"}
    assert all("features" in k for k in data["curves"])
    assert out.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.slow
def test_check_command_exit_codes(capsys):
    assert main(["check", str(example_path("gallery")), "--lss", "2", "--samples", "5"]) == 0
    assert "0 point, 0 piece and 0 line disagreements" in capsys.readouterr().out


@pytest.mark.parametrize("cmd", ["decompose", "analyze", "check"])
@pytest.mark.parametrize(("lss", "message"), [("0", "lss must be"), ("-2", "lss must be"),
                                              ("inf", "lss must be")])
def test_pipeline_commands_reject_bad_lss(capsys, cmd, lss, message):
    assert main([cmd, str(example_path("rectangle")), "--lss", lss]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err


def test_pipeline_commands_reject_bad_map(capsys, tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"boundary": [[0, 0], [2, 2], [2, 0], [0, 2]]}')
    for cmd in ("decompose", "analyze", "check"):
        assert main([cmd, str(bad), "--lss", "1"]) == 2
        assert "intersects itself" in capsys.readouterr().err


def test_progress_bar_only_on_a_terminal():
    import io

    from tether._util.progress import Progress

    class Tty(io.StringIO):
        def isatty(self):
            return True

    quiet, tty = io.StringIO(), Tty()
    for stream in (quiet, tty):
        p = Progress("decompose", stream)
        p("curves", 0.5)
        p("done", 1.0)
    assert quiet.getvalue() == ""
    assert "decompose [" in tty.getvalue() and "100%" in tty.getvalue()


def test_decompose_json_is_lean_by_default(capsys):
    data = run_json(capsys, ["decompose", str(example_path("rectangle")), "--lss", "1",
                             "--json"])
    assert set(data) >= {"counts", "regions", "cells"}
    assert "pieces" not in data and "curves" not in data
    assert data["counts"]["regions"] == len(data["regions"]) == 19


@pytest.mark.slow
def test_cli_import_is_light():
    """The CLI's start-up does not import networkx or matplotlib (fresh interpreter)."""
    import subprocess
    import sys

    code = ("import sys, tether.cli, tether.cli.maps, tether.analysis; tether.cli.build_parser();"
            "print(sorted(m for m in ('networkx', 'matplotlib') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "[]"
