"""The decomposition store: round trip equal, the same analysis, malformed or incomplete
stores refused in one line, nothing half-written left behind."""

import json
import os
from pathlib import Path

import numpy as np
import pytest
from conftest import GENERIC

import tether.decomposition.store as S
from tether.analysis import analyze
from tether.cli import main
from tether.decomposition import decompose
from tether.errors import InvalidParameterError, OutputPathError
from tether.examples import path as example_path
from tether.io import load_map


class _Lazy(dict):
    """Decompositions made when a test first asks for one."""

    MAKE = {"gallery": lambda: decompose(load_map(example_path("gallery")), 2.0),
            "rectangle": lambda: decompose(load_map(example_path("rectangle")), 1.0),
            "generic": lambda: decompose(GENERIC, 3.0)}

    def __missing__(self, name):
        self[name] = self.MAKE[name]()
        return self[name]


@pytest.fixture(scope="module")
def decs():
    """Decompositions of bundled maps (read from files, in their own frames) and of a map
    given as an Environment."""
    return _Lazy()


def _same(a, b) -> None:
    """Every column and object of two decompositions equal (pieces, regions, cells, curves,
    crossing arcs, cell codes, the lean and the full JSON)."""
    assert repr(a) == repr(b)
    assert a.to_dict(geometry=True) == b.to_dict(geometry=True)
    assert a.env.to_dict() == b.env.to_dict()
    assert a.lss == b.lss and a.curve_tol == b.curve_tol
    assert a.unresolved_pieces == b.unresolved_pieces
    assert a.unresolved_longest == b.unresolved_longest
    for x, y in zip(a.cell_codes(), b.cell_codes(), strict=True):
        assert np.array_equal(x, y)
    ta, tb = a.crossing_arcs(), b.crossing_arcs()
    for f in ("point", "start", "end", "start_code", "end_code", "full"):
        assert np.array_equal(getattr(ta, f), getattr(tb, f))
    assert list(a.pieces) == list(b.pieces)
    assert [r.structure for r in a.regions] == [r.structure for r in b.regions]
    assert all(p.equals_exact(q, 0) for p, q in zip(
        [r.polygon for r in a.regions], [r.polygon for r in b.regions], strict=True))
    for c, d in zip(a.curves, b.curves, strict=True):
        assert (c.id, c.kind, c.features, c.domain, c.intervals) == \
            (d.id, d.kind, d.features, d.domain, d.intervals)
        assert all(np.array_equal(p, q) for p, q in zip(c.polylines, d.polylines, strict=True))
        assert all(np.array_equal(p, q) for p, q in zip(c.params, d.params, strict=True))
        t = 0.5 * sum(c.intervals[0])
        assert np.array_equal(c.point(t), d.point(t)) and c.rod_angle(t) == d.rod_angle(t)
        q = c.point(t) + 0.01
        assert c.project(q)[0] == d.project(q)[0]


@pytest.mark.slow
def test_round_trip_equal_and_analysis_equal(tmp_path):
    dec = decompose(GENERIC, 3.0)  # fresh: polygons in the internal frame, unions not made
    back = S.read_decomposition(S.write_decomposition(dec, tmp_path / "store", parts=2))
    with np.load(tmp_path / "store" / "part-00001" / "regions.npz") as z:
        assert z["internal_frame"].all() and z["union_ptr"][-1] > 0  # written as held
    _same(dec, back)
    quick = {"self_check": False, "near_critical": False}
    assert analyze(back, **quick).to_dict() == analyze(dec, **quick).to_dict()


@pytest.mark.slow
@pytest.mark.parametrize(("name", "parts"), [("gallery", 1), ("gallery", 4), ("generic", 1)])
def test_round_trip_equal_and_full_analysis_equal(decs, tmp_path, name, parts):
    dec = decs[name]
    back = S.read_decomposition(S.write_decomposition(dec, tmp_path / "store", parts=parts))
    _same(dec, back)
    assert analyze(back).to_dict() == analyze(dec).to_dict()  # the self-check included


def test_parts_concatenate_to_the_whole(decs, tmp_path):
    dec = decs["rectangle"]
    S.write_decomposition(dec, tmp_path / "one")
    S.write_decomposition(dec, tmp_path / "five", parts=5)
    index = json.loads((tmp_path / "five" / "index.json").read_text())
    assert [p["name"] for p in index["parts"]] == [f"part-{k:05d}" for k in range(5)]
    rows = [p["rows"]["regions"] for p in index["parts"]]
    assert rows[0][0] == 0 and rows[-1][1] == len(dec.regions)
    assert all(a[1] == b[0] for a, b in zip(rows, rows[1:], strict=False))
    for table in S.TABLES:
        whole = np.load(tmp_path / "one" / "part-00000" / f"{table}.npz")
        got = S._concat([dict(np.load(tmp_path / "five" / p["name"] / f"{table}.npz"))
                         for p in index["parts"]])
        assert set(whole.files) == set(got)
        for k in whole.files:
            if table != "arcs":  # (version 2: each part's arcs are its pieces')
                assert np.array_equal(whole[k], got[k]), (table, k)
    # the arcs: each part's those of its pieces, joined back into the whole table
    counts = [int(np.diff(p["rows"]["pieces"])[0]) for p in index["parts"]]
    assert sum(counts) == len(dec.pieces) and min(counts) > 0
    got = S._part_arc_table([tmp_path / "five" / p["name"] / "arcs.npz"
                             for p in index["parts"]], "five", counts)
    with np.load(tmp_path / "one" / "part-00000" / "arcs.npz") as whole:
        for k, f in [("point", "point"), ("start", "start"), ("end", "end"),
                     ("start_code", "start_code"), ("end_code", "end_code"),
                     ("full_points", "full")]:
            assert np.array_equal(whole[k], getattr(got, f)), k
    ref = dec.crossing_arcs()
    assert np.array_equal(ref.point, got.point) and np.array_equal(ref.full, got.full)


def test_documented_columns_are_written(decs, tmp_path):
    S.write_decomposition(decs["rectangle"], tmp_path / "s")
    for table, cols in S.TABLES.items():
        with np.load(tmp_path / "s" / "part-00000" / f"{table}.npz") as z:
            assert set(cols) <= set(z.files), table
            assert all(z[k].dtype != object for k in z.files)


def test_cli_decompose_out_then_analyze_from(tmp_path, capsys):
    rect = str(example_path("rectangle"))
    store = str(tmp_path / "r")
    assert main(["decompose", rect, "--lss", "1", "--out", store]) == 0
    assert f"written to {store}" in capsys.readouterr().out
    assert main(["analyze", rect, "--lss", "1", "--json"]) == 0
    direct = capsys.readouterr().out
    assert main(["analyze", "--from", store, "--json"]) == 0
    assert capsys.readouterr().out == direct


@pytest.mark.slow
def test_cli_analyze_from_a_store_prints_the_same(tmp_path, capsys):
    gallery = str(example_path("gallery"))
    store = str(tmp_path / "g")
    assert main(["decompose", gallery, "--lss", "2", "--out", store]) == 0
    capsys.readouterr()
    for extra in ([], ["--json"]):
        assert main(["analyze", gallery, "--lss", "2", *extra]) == 0
        direct = capsys.readouterr().out
        assert main(["analyze", "--from", store, *extra]) == 0
        assert capsys.readouterr().out == direct


def _refused(capsys, argv, *words):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("tether: error: "), err
    for w in words:
        assert w in err[0]


def _break(store: Path, how: str) -> None:
    part = store / "part-00001"
    if how == "no index":
        (store / "index.json").unlink()
    elif how == "bad json":
        (store / "index.json").write_text("{not json")
    elif how == "other format":
        (store / "index.json").write_text(json.dumps({"format": "x", "version": 1}))
    elif how == "newer version":
        index = json.loads((store / "index.json").read_text())
        index["version"] = 99
        (store / "index.json").write_text(json.dumps(index))
    elif how == "missing table":
        (part / "pieces.npz").unlink()
    elif how == "truncated table":
        data = (part / "cells.npz").read_bytes()
        (part / "cells.npz").write_bytes(data[: len(data) // 2])
    elif how == "missing column":
        with np.load(part / "regions.npz") as z:
            cols = {k: z[k] for k in z.files if k != "area"}
        np.savez(part / "regions.npz", **cols)
    elif how == "pickled column":
        with np.load(part / "cells.npz") as z:
            cols = {k: z[k] for k in z.files}
        cols["region"] = np.array([object()] * 3, dtype=object)
        np.savez(part / "cells.npz", **cols)
    elif how == "a part left out":
        index = json.loads((store / "index.json").read_text())
        index["parts"] = index["parts"][:1]
        (store / "index.json").write_text(json.dumps(index))
    elif how == "no parts":
        index = json.loads((store / "index.json").read_text())
        index["parts"] = []
        (store / "index.json").write_text(json.dumps(index))


@pytest.mark.parametrize("how", ["no index", "bad json", "other format", "newer version",
                                 "missing table", "truncated table", "missing column",
                                 "pickled column", "a part left out", "no parts"])
def test_malformed_store_refused_in_one_line(decs, tmp_path, capsys, how):
    store = tmp_path / "s"
    S.write_decomposition(decs["rectangle"], store, parts=2)
    _break(store, how)
    with pytest.raises(InvalidParameterError):
        S.read_decomposition(store)
    _refused(capsys, ["analyze", "--from", str(store)], repr(str(store)))


def test_not_a_folder_refused(tmp_path, capsys):
    f = tmp_path / "file.txt"
    f.write_text("x")
    _refused(capsys, ["analyze", "--from", str(f)], "not a folder")
    _refused(capsys, ["analyze", "--from", str(tmp_path / "missing")], "not a folder")
    _refused(capsys, ["analyze"], "MAP --lss L, or --from DIR")
    _refused(capsys, ["analyze", str(example_path("rectangle")), "--from", str(tmp_path)],
             "not both")


def test_failed_write_leaves_nothing(decs, tmp_path, monkeypatch):
    calls = []

    def failing(path, **cols):
        calls.append(path)
        if len(calls) == 3:
            raise OSError(28, "No space left on device")
        real(path, **cols)

    real = np.savez
    monkeypatch.setattr(S.np, "savez", failing)
    with pytest.raises(OutputPathError, match="No space left"):
        S.write_decomposition(decs["generic"], tmp_path / "s")
    assert os.listdir(tmp_path) == []  # neither the store nor its temporary folder
    monkeypatch.setattr(S.np, "savez", real)
    S.write_decomposition(decs["generic"], tmp_path / "s")
    before = {p: p.read_bytes() for p in (tmp_path / "s").rglob("*") if p.is_file()}
    calls.clear()
    monkeypatch.setattr(S.np, "savez", failing)
    with pytest.raises(OutputPathError):
        S.write_decomposition(decs["rectangle"], tmp_path / "s")
    after = {p: p.read_bytes() for p in (tmp_path / "s").rglob("*") if p.is_file()}
    assert after == before and os.listdir(tmp_path) == ["s"]  # the earlier store, untouched


def test_interrupted_write_leaves_nothing(decs, tmp_path, monkeypatch):
    def interrupted(*args, **kw):
        raise KeyboardInterrupt

    monkeypatch.setattr(S.np, "savez", interrupted)
    with pytest.raises(KeyboardInterrupt):
        S.write_decomposition(decs["generic"], tmp_path / "s")
    assert os.listdir(tmp_path) == []


def test_existing_store_replaced_other_folders_refused(decs, tmp_path, capsys):
    S.write_decomposition(decs["rectangle"], tmp_path / "s")
    S.write_decomposition(decs["generic"], tmp_path / "s")  # a store: replaced
    assert S.read_decomposition(tmp_path / "s").env.name == GENERIC.name
    assert sorted(os.listdir(tmp_path)) == ["s"]
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("mine")
    with pytest.raises(OutputPathError, match="not empty"):
        S.write_decomposition(decs["generic"], tmp_path / "other")
    # the CLI refuses it before decomposing
    _refused(capsys, ["decompose", str(example_path("rectangle")), "--lss", "1", "--out",
                      str(tmp_path / "other")], "not empty")
    assert os.listdir(tmp_path / "other") == ["notes.txt"]
    (tmp_path / "empty").mkdir()
    S.write_decomposition(decs["generic"], tmp_path / "empty")  # an empty folder: used
    assert (tmp_path / "empty" / "index.json").is_file()
