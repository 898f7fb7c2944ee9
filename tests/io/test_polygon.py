"""Map files: the readers agree, validation and format errors name the file (library and CLI),
the writers, and the deprecated names of the readers."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import SQUARE_HOLE

from tether import InvalidMapError, load_map
from tether.cli import main
from tether.errors import InvalidParameterError, OutputPathError
from tether.io import from_dict, save_map
from tether.io.polygon import text_of


def test_readers_agree(tmp_path):
    wkt = tmp_path / "m.wkt"
    wkt.write_text("POLYGON ((0 0, 12 0, 12 12, 0 12, 0 0), (4 4, 4 6, 6 6, 6 4, 4 4))")
    geo = tmp_path / "m.geojson"
    ring = [[0, 0], [12, 0], [12, 12], [0, 12], [0, 0]]
    hole = [[4, 4], [4, 6], [6, 6], [6, 4], [4, 4]]
    geo.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"name": "g"},
         "geometry": {"type": "Polygon", "coordinates": [ring, hole]}}]}))
    js = tmp_path / "m.json"
    save_map(SQUARE_HOLE, js)
    maps = [load_map(p) for p in (wkt, geo, js)]
    for m in maps:
        assert np.allclose(m.vertices, SQUARE_HOLE.vertices)
        assert m.area == pytest.approx(140.0)
    assert maps[1].name == "g"
    assert json.loads(js.read_text())["holes"] == [SQUARE_HOLE.holes[0].tolist()]


BAD_MAPS = [
    ({"boundary": [[0, 0], [1, 0]]}, "at least 3 distinct vertices"),
    ({"boundary": [[0, 0], [1, 0], [1, 0], [0, 1]]}, "repeat the same point"),
    ({"boundary": [[0, 0], [2, 2], [2, 0], [0, 2]]}, "intersects itself near (1, 1)"),
    ({"boundary": [[0, 0], [1, 0], [2, 0]]}, "zero area"),
    ({"boundary": [[0, 0], [4, 0], [4, 4], [0, 4]], "holes": [[[5, 5], [6, 5], [6, 6]]]},
     "hole 0: not inside the boundary"),
    ({"boundary": [[0, 0], [4, 0], [4, 4], [0, 4]], "holes": [[[0, 1], [1, 1], [1, 2]]]},
     "vertex V4 (0, 1) of hole 0 lies on edge E3 of the boundary"),
    ({"boundary": [[0, 0], [9, 0], [9, 9], [0, 9]],
      "holes": [[[1, 1], [3, 1], [3, 3]], [[2, 1.5], [4, 1.5], [4, 4]]]},
     "holes 0 and 1 overlap"),
    ({"boundary": [[0, 0], [1, 0], [float("nan"), 1]]}, "non-finite coordinate"),
    ({"boundary": [[0, 0], [1, 0], [0, 1]], "colour": "red"}, "unknown key(s) colour"),
    ({"holes": []}, "missing key 'boundary'"),
    ({"boundary": [[0, 0, 0], [1, 0, 0], [0, 1, 0]]}, "list of [x, y] pairs"),
]


@pytest.mark.parametrize(("data", "message"), BAD_MAPS)
def test_validation_errors_library_and_cli(tmp_path, capsys, data, message):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data).replace("NaN", "NaN"))
    with pytest.raises(InvalidMapError, match=None) as info:
        load_map(path)
    assert message in str(info.value)
    assert str(path) in str(info.value)
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and "Traceback" not in err


@pytest.mark.parametrize(("name", "text", "message"), [
    ("m.json", '{"boundary": [[0, 0], [1, 0]\n  [0, 1]]}', "malformed JSON at line 2, column 3"),
    ("m.txt", "whatever", "unknown map format '.txt'"),
    ("m.wkt", "POLYGON ((0 0, 1 0", "malformed WKT"),
    ("m.wkt", "LINESTRING (0 0, 1 0)", "WKT must be a POLYGON"),
    ("m.geojson", '{"type": "Point", "coordinates": [0, 0]}', "must be a Polygon"),
])
def test_file_format_errors(tmp_path, capsys, name, text, message):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(InvalidMapError) as info:
        load_map(path)
    assert message in str(info.value)
    assert main(["info", str(path)]) == 2
    assert message in capsys.readouterr().err


def test_missing_file(capsys):
    assert main(["info", "/nonexistent/map.json"]) == 2
    assert "cannot read" in capsys.readouterr().err


@pytest.mark.parametrize("suffix", [".json", ".geojson", ".wkt"])
def test_save_map_round_trips(tmp_path, suffix):
    path = tmp_path / f"m{suffix}"
    save_map(SQUARE_HOLE, path)
    back = load_map(path)
    assert back.to_dict() == SQUARE_HOLE.to_dict() | {"name": back.name}
    assert path.read_text() == text_of(SQUARE_HOLE, suffix)


def test_save_map_writes_what_convert_writes(tmp_path, capsys):
    """``tether convert`` and :func:`save_map` write the same bytes."""
    src = tmp_path / "src.json"
    save_map(SQUARE_HOLE, src)
    for suffix in (".json", ".geojson", ".wkt"):
        assert main(["convert", str(src), str(tmp_path / f"cli{suffix}")]) == 0
        save_map(load_map(src), tmp_path / f"lib{suffix}")
        assert (tmp_path / f"cli{suffix}").read_bytes() == (tmp_path / f"lib{suffix}").read_bytes()
    capsys.readouterr()


def test_save_map_ros_needs_a_resolution(tmp_path):
    with pytest.raises(InvalidParameterError, match="needs a resolution"):
        save_map(SQUARE_HOLE, tmp_path / "m.yaml")
    with pytest.raises(InvalidParameterError, match="ROS map"):
        save_map(SQUARE_HOLE, tmp_path / "m.json", resolution=0.1)
    with pytest.raises(OutputPathError, match="unknown extension"):
        save_map(SQUARE_HOLE, tmp_path / "m.txt")
    save_map(SQUARE_HOLE, tmp_path / "m.yaml", resolution=0.25)
    assert (tmp_path / "m.pgm").exists()
    assert load_map(tmp_path / "m.yaml").n > 0


def test_a_map_without_a_name_is_named_after_its_file(tmp_path):
    path = tmp_path / "room.json"
    path.write_text(json.dumps({"boundary": [[0, 0], [4, 0], [4, 4], [0, 4]], "name": ""}))
    assert load_map(path).name == "room"
    assert from_dict({"boundary": [[0, 0], [4, 0], [4, 4]]}, name="given").name == "given"
    assert from_dict({"boundary": [[0, 0], [4, 0], [4, 4]], "name": "own"}, name="x").name == "own"


@pytest.mark.parametrize("name", ["load_map", "from_dict", "from_geojson", "from_wkt"])
def test_readers_deprecated_in_environment(name):
    import tether.environment
    import tether.io

    with pytest.warns(DeprecationWarning, match=f"tether.io.{name}"):
        old = getattr(tether.environment, name)
    assert old is getattr(tether.io, name)


def test_environment_save_deprecated(tmp_path):
    with pytest.warns(DeprecationWarning, match="tether.io.save_map"):
        SQUARE_HOLE.save(tmp_path / "old.json")
    save_map(SQUARE_HOLE, tmp_path / "new.json")
    assert (tmp_path / "old.json").read_bytes() == (tmp_path / "new.json").read_bytes()


def test_unknown_attribute_of_environment():
    import tether.environment

    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        tether.environment.nothing  # noqa: B018
