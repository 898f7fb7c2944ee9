"""A store read for analysis makes no per-object record and decodes no geometry (#25 item 4):
polygons and lines stay WKB until read, curves are made on their first read, and a store is
written one part's columns at a time. The decoded geometries are compared with the
decomposition's own, exactly."""

import math

import numpy as np
import pytest

import tether.decomposition.store as S
from tether import Environment
from tether.analysis import analyze
from tether.decomposition import decompose
from tether.decomposition.model import Regions
from tether.errors import InvalidParameterError

QUICK = {"self_check": False, "near_critical": False}
ELL = Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])


@pytest.fixture(scope="module")
def stored(tmp_path_factory):
    dec = decompose(ELL, 0.5)
    path = S.write_decomposition(dec, tmp_path_factory.mktemp("s") / "store", parts=3)
    return dec, path


def test_analysis_from_a_store_decodes_no_geometry_and_makes_no_curve(stored):
    dec, path = stored
    back = S.read_decomposition(path)
    shapes, lines = back.regions._table.shapes, back.pieces._table.shapes
    assert type(back.regions) is Regions and type(back.curves) is S.StoredCurves
    assert shapes._held is None and lines._held is None and back.curves._done is None
    assert analyze(back, **QUICK).to_dict() == analyze(dec, **QUICK).to_dict()
    assert shapes._held is None and lines._held is None and back.curves._done is None
    assert callable(shapes._wkb[0]) and callable(lines._wkb[0])  # the bytes not even read
    assert len(back.curves) == len(dec.curves) and back.curves._done is None


def test_some_polygons_decoded_alone_equal_the_whole(stored):
    dec, path = stored
    back = S.read_decomposition(path)
    ids = np.array([0, 7, len(dec.regions) - 1])
    some = back.region_polygons(ids)
    assert back.regions._table.shapes._held is None  # only those decoded
    want = dec.region_polygons(ids)
    assert all(a.equals_exact(b, 0) for a, b in zip(some, want, strict=True))
    got = [r.polygon for r in back.regions]  # every polygon: decoded all at once
    assert all(a.equals_exact(b.polygon, 0) for a, b in zip(got, dec.regions, strict=True))
    assert [p.geometry.wkb for p in back.pieces] == [p.geometry.wkb for p in dec.pieces]
    assert [(c.id, c.kind, c.features, c.intervals) for c in back.curves] == [
        (c.id, c.kind, c.features, c.intervals) for c in dec.curves]
    assert back.curves[0] is back.curves[0]  # made once, kept


def test_written_one_part_at_a_time(stored, tmp_path, monkeypatch):
    dec, _ = stored
    _ = [r.polygon for r in dec.regions], [p.geometry for p in dec.pieces]  # held decoded
    sizes = []
    real = S._wkb

    def counted(geoms):
        sizes.append(len(geoms))
        return real(geoms)

    monkeypatch.setattr(S, "_wkb", counted)
    S.write_decomposition(dec, tmp_path / "s", parts=4)
    most = math.ceil(max(len(dec.regions), len(dec.pieces)) / 4)
    assert sizes and max(sizes) <= most  # no column of every geometry made at once


def test_a_column_read_later_is_checked_now_and_refused_when_read(stored, tmp_path):
    dec, _ = stored
    path = S.write_decomposition(dec, tmp_path / "s", parts=2)
    part = path / "part-00001" / "pieces.npz"
    with np.load(part) as z:
        cols = {k: z[k] for k in z.files}
    np.savez(part, **{k: v for k, v in cols.items() if k != "geometry_wkb"})
    with pytest.raises(InvalidParameterError, match="lacks the column"):
        S.read_decomposition(path)  # refused at once, though read only when used
    cols["geometry_wkb"] = np.array([object()], dtype=object)  # a pickled column
    np.savez(part, **cols)
    back = S.read_decomposition(path)
    with pytest.raises(InvalidParameterError, match="cannot be read"):
        _ = back.pieces[0].geometry


def test_a_store_read_pickles_with_its_columns_still_unread(stored):
    import pickle

    dec, path = stored
    back = pickle.loads(pickle.dumps(S.read_decomposition(path)))
    assert callable(back.pieces._table.shapes._wkb[0])
    assert analyze(back, **QUICK).to_dict() == analyze(dec, **QUICK).to_dict()
    assert [p.geometry.wkb for p in back.pieces] == [p.geometry.wkb for p in dec.pieces]
