"""Track files: CSV and JSON read and written (round trip), and every malformed input refused in
one line naming the file and what is wrong."""

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tether.errors import InvalidParameterError, InvalidTrackError, OutputPathError
from tether.io.tracks import Track, read_track, write_track


def test_csv_default_and_chosen_columns(tmp_path):
    f = tmp_path / "walk.csv"
    f.write_text("# a person\nt, x, y\n0, 1, 2\n0.5, 1.5, 2\n\n1.0, 1.5, 3\n")
    tr = read_track(f)
    assert tr.name == "walk"
    assert tr.t.tolist() == [0.0, 0.5, 1.0]
    assert tr.xy.tolist() == [[1, 2], [1.5, 2], [1.5, 3]]
    g = tmp_path / "odom.txt"
    g.write_text("seq,stamp,py,px\n1,10,2,1\n2,11,3,1\n")
    tr = read_track(g, columns=("stamp", "px", "py"))
    assert tr.t.tolist() == [10, 11] and tr.xy.tolist() == [[1, 2], [1, 3]]


def test_json_both_forms(tmp_path):
    f = tmp_path / "a.json"
    f.write_text(json.dumps({"name": "alice", "t": [0, 1], "xy": [[0, 0], [1, 1]],
                             "meta": {"frame_id": "map"}}))
    tr = read_track(f)
    assert (tr.name, tr.meta, tr.xy.tolist()) == ("alice", {"frame_id": "map"},
                                                  [[0, 0], [1, 1]])
    g = tmp_path / "b.json"
    g.write_text(json.dumps([{"t": 0, "x": 1, "y": 2}, {"t": 2, "x": 3, "y": 4}]))
    assert read_track(g).position(1.0).tolist() == [2.0, 3.0]
    h = tmp_path / "c.json"
    h.write_text(json.dumps([{"s": 0, "u": 1, "v": 2}, {"s": 2, "u": 3, "v": 4}]))
    assert read_track(h, columns=("s", "u", "v")).xy.tolist() == [[1, 2], [3, 4]]


def test_an_unknown_suffix_is_read_by_its_content(tmp_path):
    f = tmp_path / "track.dat"
    f.write_text('{"t": [0], "xy": [[1, 2]]}')
    assert read_track(f).xy.tolist() == [[1, 2]]
    f.write_text("t,x,y\n0,1,2\n")
    assert read_track(f).xy.tolist() == [[1, 2]]


finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)


@settings(max_examples=15, deadline=None)
@given(st.lists(st.tuples(st.floats(1e-6, 100), finite, finite), min_size=1, max_size=20),
       st.floats(-1e6, 1e6), st.sampled_from([".csv", ".json"]))
def test_round_trip_is_exact(tmp_path_factory, rows, t0, suffix):
    t = t0 + np.cumsum([r[0] for r in rows])
    if np.any(np.diff(t) <= 0):
        return  # the steps vanished in t0's rounding: not a track
    tr = Track(t, [r[1:] for r in rows], "walk")
    f = tmp_path_factory.mktemp("rt") / f"walk{suffix}"
    write_track(tr, f)
    back = read_track(f)
    assert np.array_equal(back.t, tr.t) and np.array_equal(back.xy, tr.xy)
    assert back.name == "walk"


def test_write_is_atomic_and_checks_the_path(tmp_path):
    tr = Track([0, 1], [(0, 0), (1, 0)])
    with pytest.raises(OutputPathError, match="unknown extension"):
        write_track(tr, tmp_path / "walk.xml")
    with pytest.raises(OutputPathError, match="does not exist"):
        write_track(tr, tmp_path / "nowhere" / "walk.csv")
    write_track(tr, tmp_path / "walk.csv")
    assert [p.name for p in tmp_path.iterdir()] == ["walk.csv"]  # no temporary left behind


MALFORMED = [
    ("empty.csv", "", "empty track"),
    ("header_only.csv", "t,x,y\n", "empty track (no samples)"),
    ("no_column.csv", "t,x,z\n0,1,2\n", "no column 'y' (the header has t, x, z)"),
    ("text.csv", "t,x,y\n0,1,2\n1,one,2\n", "line 3: x is not a number ('one')"),
    ("nan.csv", "t,x,y\n0,1,2\n1,nan,2\n", "line 3: x is not a finite number ('nan')"),
    ("inf.csv", "t,x,y\n0,1,2\ninf,1,2\n", "line 3: t is not a finite number"),
    ("backwards.csv", "t,x,y\n0,1,2\n2,1,2\n1,1,2\n", "line 4: times must increase strictly"),
    ("repeated.csv", "t,x,y\n0,1,2\n0,1,3\n", "line 3: times must increase strictly"),
    ("truncated.csv", "t,x,y\n0,1,2\n1,1", "line 3: 2 fields, the header has 3"),
    ("binary.csv", b"t,x,y\n\x00\x01", "not a text file"),
    ("latin1.csv", b"t,x,y\n0,1,2\xe9\n", "not UTF-8 text"),
    ("truncated.json", '{"t": [0, 1], "xy": [[0, 0], [1', "bad JSON at line 1 column"),
    ("no_xy.json", '{"t": [0, 1]}', "no 'xy' in the JSON object"),
    ("lengths.json", '{"t": [0, 1], "xy": [[0, 0]]}', "'t' and 'xy' must be lists of the "
     "same length"),
    ("pair.json", '{"t": [0], "xy": [[0, 0, 0]]}', "xy[0] is not an [x, y] pair"),
    ("string.json", '{"t": ["0"], "xy": [[0, 0]]}', None),  # a numeric string is a number
    ("bool.json", '{"t": [true], "xy": [[0, 0]]}', "sample 0: t is not a number (True)"),
    ("null.json", '[{"t": 0, "x": null, "y": 1}]', "item 0: x is not a number (None)"),
    ("missing.json", '[{"t": 0, "x": 1}]', "item 0 has no 'y'"),
    ("not_obj.json", '[[0, 1, 2]]', "item 0 is not an object"),
    ("scalar.json", '3', "a JSON track is an object"),
    ("empty.json", '[]', "empty track (no samples)"),
    ("order.json", '[{"t": 1, "x": 0, "y": 0}, {"t": 1, "x": 1, "y": 0}]',
     "item 1: times must increase strictly"),
]


@pytest.mark.parametrize("name, content, words", MALFORMED, ids=[m[0] for m in MALFORMED])
def test_malformed_tracks_one_line(tmp_path, name, content, words):
    f = tmp_path / name
    if isinstance(content, bytes):
        f.write_bytes(content)
    else:
        f.write_text(content)
    if words is None:
        assert len(read_track(f)) == 1
        return
    with pytest.raises(InvalidTrackError) as err:
        read_track(f)
    msg = str(err.value)
    assert msg.startswith(f"{f}: ") and words in msg and "\n" not in msg


def test_missing_file_and_misplaced_options(tmp_path):
    with pytest.raises(InvalidTrackError, match="no such track file"):
        read_track(tmp_path / "none.csv")
    f = tmp_path / "w.csv"
    f.write_text("t,x,y\n0,0,0\n")
    with pytest.raises(InvalidTrackError, match="a topic applies to ROS bags only"):
        read_track(f, topic="/person")
    with pytest.raises(InvalidTrackError, match="three names"):
        read_track(f, columns=("t", "x"))
    with pytest.raises(InvalidTrackError, match="three different names"):
        read_track(f, columns=("t", "x", "x"))


def test_the_track_error_is_a_parameter_error():
    """Callers that catch InvalidParameterError (the Track checks raised it) still do."""
    with pytest.raises(InvalidParameterError):
        Track([1, 0], [(0, 0), (1, 1)])
