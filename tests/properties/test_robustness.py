"""Never a traceback: each class of bad input ends in one line and exit status 2, nothing left
behind. One representative per class; ``tools/bad_input_corpus.py`` runs hundreds."""

from __future__ import annotations

import json
import os
import warnings

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tether.cli import main
from tether.errors import InvalidMapError, TetherError
from tether.io import from_dict, from_geojson, load_map

SQUARE = {"name": "square", "boundary": [[0, 0], [4, 0], [4, 3], [0, 3]], "holes": []}


def run(capsys, argv, status=2):
    """Run ``tether argv``; assert the exit status and (on error) a single stderr line."""
    got = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert got == status, err
    assert "Traceback" not in err
    if status == 2:
        assert err.count("\n") == 1 and "error: " in err, err
    return out, err


@pytest.fixture
def in_tmp(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "m.json").write_text(json.dumps(SQUARE))
    return tmp_path


def files(folder):
    return sorted(p.name for p in folder.iterdir())


# ---------------------------------------------------------------------- input files
@pytest.mark.parametrize(("content", "fragment"), [
    (b"\x89PNG\r\n\x1a\n" + bytes(100), "a binary file, not a map"),
    ('{"name": "caf\xe9", "boundary": []}'.encode("latin-1"), "not UTF-8 text (byte 0xe9"),
    (b"[" * 50_000 + b"]" * 50_000, "nested too deeply"),
    (b'{"boundary": [[0, 0], [' + b"9" * 5000 + b", 0], [0, 1]]}", "integer of 5000 digits"),
    (b'{"boundary": [[0, 0], [1e400, 0], [0, 1]]}', "boundary[1][0]: non-finite coordinate"),
    (b"", "the file is empty"),
])
def test_unreadable_files(in_tmp, capsys, content, fragment):
    (in_tmp / "bad.json").write_bytes(content)
    _, err = run(capsys, ["info", "bad.json"])
    assert fragment in err and "bad.json" in err


def test_utf16_and_utf32_json_are_read(in_tmp):
    text = json.dumps(SQUARE)
    for codec in ("utf-16", "utf-16-le", "utf-32", "utf-8-sig"):
        (in_tmp / "u.json").write_bytes(text.encode(codec))
        assert load_map(in_tmp / "u.json").n == 4


@pytest.mark.parametrize(("data", "message"), [
    ({"boundary": [[0, 0], [1, 0], [0, 1]], "holes": [[[0.1, 0.1], [0.2, 0.1], [0.1, "3"]]]},
     'holes[0][2][1]: expected a number, got "3"'),
    ({"boundary": [[0, 0], [True, 0], [0, 1]]}, "boundary[1][0]: expected a number, got true"),
    ({"boundary": [[0, 0], [1, None], [0, 1]]}, "boundary[1][1]: expected a number, got null"),
    ({"boundary": "0 0 1 0 0 1"}, "boundary: expected a list of [x, y] pairs"),
    ({"boundary": [[0, 0], [1, 0], [0, 1]], "holes": {}}, "holes: expected a list of rings"),
    ({"boundary": [[0, 0], [1, 0], [0, 1]], "name": 3}, "name: expected a string, got 3"),
])
def test_wrong_json_types_name_the_field(data, message):
    with pytest.raises(InvalidMapError) as exc:
        from_dict(data)
    assert message in str(exc.value)


def test_geojson_feature_nested_in_feature():
    poly = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [0, 1], [0, 0]]]}
    with pytest.raises(InvalidMapError, match="a Feature cannot be nested in a Feature"):
        from_geojson({"type": "Feature", "geometry": {"type": "Feature", "geometry": poly}})
    with pytest.raises(InvalidMapError, match=r"coordinates\[0\]\[1\]\[0\]: expected a number"):
        from_geojson({"type": "Polygon", "coordinates": [[[0, 0], [False, 0], [0, 1]]]})


@pytest.mark.parametrize(("wkt", "fragment"), [
    ("CIRCULARSTRING (0 0, 1 1, 2 0)", "got CIRCULARSTRING"),
    ("MULTIPOLYGON (((0 0, 1 0, 0 1, 0 0)))", "got MULTIPOLYGON"),
    ("POLYGON ((0 0, 1 0, 1 1))", "malformed WKT"),
])
def test_wkt_types_not_taken(in_tmp, capsys, wkt, fragment):
    (in_tmp / "m.wkt").write_text(wkt)
    _, err = run(capsys, ["info", "m.wkt"])
    assert fragment in err


@pytest.mark.parametrize(("data", "fragment"), [
    ({"boundary": [[0, 0], [4, 0], [4, 4], [0, 4]], "holes": [[[3, 1], [5, 1], [5, 2]]]},
     "vertex V5 (5, 1) lies outside the boundary"),
    ({"boundary": [[0, 0], [9, 0], [9, 9], [0, 9]],
      "holes": [[[1, 1], [3, 1], [3, 3]], [[2, 1.5], [4, 1.5], [4, 4]]]},
     "holes 0 and 1 overlap near ("),
    ({"boundary": [[0, 0], [9, 0], [9, 9], [0, 9]],
      "holes": [[[1, 1], [3, 1], [3, 3]], [[3, 1], [5, 1], [5, 3], [3, 3]]]},
     "hole 0 and hole 1 touch along a segment from (3, "),
    ({"boundary": [[0, 0], [2, 2], [2, 0], [0, 2]]}, "intersects itself near (1, 1)"),
    ({"boundary": [[0, 0], [1e300, 0], [1e300, 1e300]]}, "V1 (1e+300, 0) is beyond"),
])
def test_validation_messages_give_a_location(data, fragment):
    with pytest.raises(InvalidMapError) as exc:
        from_dict(data)
    assert fragment in str(exc.value)


# ---------------------------------------------------------------------- parameters
@pytest.mark.parametrize(("argv", "fragment"), [
    (["arcs", "m.json", "--lss", "1e-12", "--at", "1", "1"], "out of range for map 'square'"),
    (["decompose", "m.json", "--lss", "1e308"], "out of range for map 'square'"),
    (["check", "m.json", "--lss", "1", "--samples", "0"], "--samples: 0 is out of range"),
    (["check", "m.json", "--lss", "1", "--seed", "-1"], "--seed: -1 is out of range"),
    (["bound", "--vt", "1", "--vo", "1e308", "--lss", "1", "--from", "0", "--to", "1"],
     "vo = 1e+308 is out of range"),
    (["bound", "--vt", "1", "--vo", "2", "--lss", "1", "--from", "0", "--to", "1e300"],
     "--to 1e+300 is out of range"),
    (["plot-motion", "tractrix", "--vt", "0", "--out", "f.png"], "needs vt > 0"),
    (["arcs", "m.json", "--lss", "1", "--at", "nan", "1"], "must be a finite number"),
])
def test_extreme_parameters(in_tmp, capsys, argv, fragment):
    _, err = run(capsys, argv)
    assert fragment in err
    assert files(in_tmp) == ["m.json"]


def test_lss_range_is_relative_to_the_map():
    from tether.arcs import check_lss
    from tether.environment import Environment
    from tether.errors import InvalidParameterError

    env = Environment(SQUARE["boundary"])  # diameter 5
    assert check_lss(0.005, env) == 0.005 and check_lss(5000, env) == 5000
    for bad in (0.004, 5001, True):
        with pytest.raises(InvalidParameterError):
            check_lss(bad, env)


def test_vt_zero_is_a_valid_bound(capsys):
    out, _ = run(capsys, ["bound", "--vt", "0", "--vo", "2", "--lss", "1", "--from", "0",
                          "--to", "1", "--json"], status=0)
    assert json.loads(out)["distance_bound"] == 0


# ---------------------------------------------------------------------- output paths
@pytest.mark.parametrize(("path", "fragment"), [
    ("nope/f.png", "does not exist"),
    ("afile/f.png", "is a file"),
    (".", "is a folder"),
    ("f", "no extension"),
    ("f.txt", "unknown extension"),
])
def test_output_path_checked_before_computing(in_tmp, capsys, monkeypatch, path, fragment):
    (in_tmp / "afile").write_text("x")
    import tether.decomposition

    def boom(*a, **k):  # the path must be refused before any computation
        raise AssertionError("computed before checking the output path")

    monkeypatch.setattr(tether.decomposition, "decompose", boom)
    _, err = run(capsys, ["decompose", "m.json", "--lss", "1", "--plot", path])
    assert fragment in err
    assert files(in_tmp) == ["afile", "m.json"]


def test_failed_save_leaves_nothing(in_tmp, capsys, monkeypatch):
    from matplotlib.figure import Figure

    def broken(self, *a, **k):
        open(a[0], "wb").write(b"half")  # noqa: SIM115 - a half-written file, then failure
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(Figure, "savefig", broken)
    _, err = run(capsys, ["plot-motion", "wall", "--out", "f.png"])
    assert "No space left on device" in err
    assert files(in_tmp) == ["m.json"]


def test_demo_out_is_a_file(in_tmp, capsys):
    (in_tmp / "afile").write_text("x")
    _, err = run(capsys, ["demo", "--out", "afile"])
    assert "is a file" in err


# ---------------------------------------------------------------------- the wrapper
def _patched(monkeypatch, fn):
    import tether.cli.maps

    monkeypatch.setattr(tether.cli.maps, "cmd_info", fn)


def test_internal_error_is_one_line_exit_3(in_tmp, capsys, monkeypatch):
    def bug(args):
        raise KeyError("oops")

    _patched(monkeypatch, bug)
    monkeypatch.delenv("TETHER_DEBUG", raising=False)
    assert main(["info", "m.json"]) == 3
    err = capsys.readouterr().err
    assert err.startswith("tether: internal error: KeyError") and err.count("\n") == 1
    monkeypatch.setenv("TETHER_DEBUG", "1")
    assert main(["info", "m.json"]) == 3
    assert "Traceback" in capsys.readouterr().err


def test_warnings_never_printed_and_messages_one_line(in_tmp, capsys, monkeypatch):
    import numpy as np

    def noisy(args):
        np.float64(1.0) / np.float64(0.0)
        warnings.warn("something odd", RuntimeWarning, stacklevel=1)
        raise TetherError("GEOS says:\nIllegalArgumentException:\n  bad ring")

    _patched(monkeypatch, noisy)
    monkeypatch.delenv("TETHER_DEBUG", raising=False)
    assert main(["info", "m.json"]) == 2
    err = capsys.readouterr().err
    assert err == "tether: error: GEOS says: IllegalArgumentException: bad ring\n"


def test_broken_pipe_is_success(in_tmp, capsys, monkeypatch):
    def pipe(args):
        raise BrokenPipeError

    _patched(monkeypatch, pipe)
    assert main(["info", "m.json"]) == 0


def test_version(capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.startswith("tether ")


def test_non_finite_json_is_a_clean_error(capsys):
    from tether.cli.common import print_json
    from tether.errors import NonFiniteResultError

    with pytest.raises(NonFiniteResultError, match=r"arcs\[1\]\.end"):
        print_json({"arcs": [{"end": 1.0}, {"end": float("inf")}]})
    assert capsys.readouterr().out == ""


# ---------------------------------------------------------------------- garbage
json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=5),
    lambda inner: st.lists(inner, max_size=5) | st.dictionaries(
        st.sampled_from(["boundary", "holes", "name", "type", "coordinates", "geometry",
                         "features", "properties", "x"]), inner, max_size=4),
    max_leaves=30)


@pytest.mark.slow
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=json_values, ext=st.sampled_from(["json", "geojson"]))
def test_garbage_json_never_a_traceback(tmp_path_factory, data, ext):
    path = tmp_path_factory.mktemp("g") / f"m.{ext}"
    path.write_text(json.dumps(data))
    try:
        load_map(path)
    except TetherError as exc:
        assert "\n" not in str(exc)


@pytest.mark.slow
@settings(max_examples=100, deadline=None)
@given(raw=st.binary(max_size=300))
def test_garbage_bytes_never_a_traceback(tmp_path_factory, raw):
    folder = tmp_path_factory.mktemp("b")
    for ext in ("json", "wkt"):
        path = folder / f"m.{ext}"
        path.write_bytes(raw)
        try:
            load_map(path)
        except TetherError as exc:
            assert "\n" not in str(exc)
    assert sorted(os.listdir(folder)) == ["m.json", "m.wkt"]


def test_every_command_has_a_help_example(capsys):
    from tether.cli import EXAMPLES, build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    for name in sub.choices:
        assert EXAMPLES.get(name, "").startswith(f"tether {name}"), name
    with pytest.raises(SystemExit):
        build_parser().parse_args(["info", "--help"])
    out = capsys.readouterr().out
    assert "example:" in out and "map files:" in out


@pytest.mark.parametrize("name", ["info", "arcs", "analyze", "bound"])
def test_help_examples_run(capsys, monkeypatch, name):
    import shlex
    from pathlib import Path

    from tether.cli import EXAMPLES

    monkeypatch.chdir(Path(__file__).resolve().parents[2])
    assert main(shlex.split(EXAMPLES[name])[1:]) == 0
