"""``tether sweep --delay``: the certified fraction per sensing delay (table, JSON) and one
clear error per bad input."""

from __future__ import annotations

import json

import pytest

from tether.cli import main
from tether.examples import path as example_path

CORNER = ["sweep", str(example_path("convex_corner")), "--lss", "1", "--vt", "0.3", "--vo", "1",
          "--h", "1"]


@pytest.mark.slow
def test_sweep_delay_json_and_table(capsys):
    """Two delays on a map whose search stops at once (no field: nothing certified, every
    row says so)."""
    assert main([*CORNER, "--delay", "0,0.5", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [r["delay"] for r in out["rows"]] == [0.0, 0.5]
    assert not any(r["certified"] for r in out["rows"])
    assert out["longest_certified_delay"] is None and out["lss"] == 1.0
    assert main([*CORNER, "--delay", "0.5"]) == 0
    text = capsys.readouterr().out
    assert "per sensing delay" in text and "no delay has a certified field" in text


@pytest.mark.parametrize("extra, message", [
    (["--delay", "0:0.5:0.1", "--csv"], "--csv does not apply to --delay"),
    (["--delay", "0:-1:0.1"], "--delay '0:-1:0.1': expected START:STOP:STEP"),
    (["--delay", "-0.1"], "delay must be a finite number >= 0"),
    (["--delay", "10"], "too long"),
    (["--h", "0.5"], "--h applies to --delay only"),
])
def test_sweep_delay_bad_input(capsys, extra, message):
    assert main([*CORNER, *extra]) == 2
    assert message in capsys.readouterr().err


def test_sweep_delay_needs_one_lss_and_speeds(capsys):
    args = ["sweep", str(example_path("convex_corner")), "--lss", "1:2:0.5", "--vt", "0.3",
            "--vo", "1", "--delay", "0"]  # refused before any map work
    assert main(args) == 2
    assert "a single --lss" in capsys.readouterr().err
    assert main(["sweep", str(example_path("convex_corner")), "--lss", "1", "--delay", "0"]) == 2
    assert "--delay needs --vt and --vo" in capsys.readouterr().err
