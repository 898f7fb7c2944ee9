"""The map model: readers, feature names, reflex flags and validation errors."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import L_SHAPE, SQUARE_HOLE

from tether import Environment, InvalidMapError, load_map
from tether.cli import main


def test_feature_numbering_follows_the_file_not_the_orientation():
    # boundary given clockwise, hole given counter-clockwise: both opposite to the convention
    env = Environment([[0, 0], [0, 12], [12, 12], [12, 0]], ([[4, 4], [6, 4], [6, 6], [4, 6]],))
    assert np.allclose(env.vertices[0], [0, 0]) and np.allclose(env.vertices[4], [4, 4])
    # edge E0 runs V0 -> V1 = (0,0)->(0,12); free side is +x, i.e. to its right
    assert not env.free_on_left[0]
    assert np.allclose(env.free_normals[0], [1, 0])
    # hole edge E4 runs (4,4)->(6,4): the free space is below it (outside the hole)
    assert np.allclose(env.free_normals[4], [0, -1])
    assert list(env.reflex_indices) == [4, 5, 6, 7]


def test_reflex_vertices_of_an_l_shape():
    assert list(L_SHAPE.reflex_indices) == [3]  # (4, 4)


def test_collinear_vertex_is_not_reflex():
    env = Environment([[0, 0], [5, 0], [10, 0], [10, 10], [0, 10]])
    assert not env.reflex.any()


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
    SQUARE_HOLE.save(js)
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
