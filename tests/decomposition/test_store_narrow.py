"""A store's columns in the narrow types the decomposition holds (#25): cells' regions int32
and codes int16, the arcs' points int32 and codes int16; stores written with int64 columns
(as before) read to the same decomposition; the pieces' samples, normals and offsets read
only when first used (G reads none of them)."""

import zipfile

import numpy as np
import pytest

import tether.decomposition.store as S
from tether import Environment
from tether.analysis import analyze, build_graph
from tether.decomposition import decompose

QUICK = {"self_check": False, "near_critical": False}
ELL = Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])


@pytest.fixture(scope="module")
def stored(tmp_path_factory):
    dec = decompose(ELL, 0.5)
    path = S.write_decomposition(dec, tmp_path_factory.mktemp("n") / "store", parts=2)
    return dec, path


def test_cells_and_arcs_written_narrow(stored):
    _, path = stored
    for part in ("part-00000", "part-00001"):
        with np.load(path / part / "cells.npz") as z:
            assert z["region"].dtype == np.int32
            assert z["start"].dtype == z["end"].dtype == np.int16
        with np.load(path / part / "arcs.npz") as z:
            assert z["point"].dtype == np.int32
            assert z["start_code"].dtype == z["end_code"].dtype == np.int16


def _widened(src, dst):
    """A copy of the store ``src`` with every int column of cells and arcs in int64 (a store
    written before the narrow types)."""
    dst.mkdir()
    for item in src.iterdir():
        if item.is_file():
            (dst / item.name).write_bytes(item.read_bytes())
            continue
        (dst / item.name).mkdir()
        for f in item.iterdir():
            with np.load(f) as z:
                cols = {k: (z[k].astype(np.int64) if z[k].dtype.kind == "i" else z[k])
                        for k in z.files}
            np.savez(dst / item.name / f.name, **cols)
    return dst


@pytest.mark.slow
def test_int64_stores_read_the_same(stored, tmp_path):
    dec, path = stored
    old = _widened(path, tmp_path / "old")
    with np.load(old / "part-00000" / "cells.npz") as z:
        assert z["region"].dtype == np.int64
    a, b = S.read_decomposition(path), S.read_decomposition(old)
    for x, y in zip(a.cell_codes(), b.cell_codes(), strict=True):
        assert np.array_equal(x, y) and x.dtype == y.dtype  # held narrow either way
    ta, tb = a.crossing_arcs(), b.crossing_arcs()
    for f in ("point", "start", "end", "start_code", "end_code", "full"):
        assert np.array_equal(getattr(ta, f), getattr(tb, f))
    assert analyze(b, **QUICK).to_dict() == analyze(dec, **QUICK).to_dict()


def test_piece_samples_read_when_first_used(stored):
    dec, path = stored
    back = S.read_decomposition(path)
    t = back.pieces._table
    assert callable(t._q) and callable(t._n) and callable(t._eps)
    g = build_graph(back)
    assert g.n_edges == build_graph(dec).n_edges
    assert callable(t._q) and callable(t._n) and callable(t._eps)  # G read none of them
    want = dec.pieces._table
    assert np.array_equal(t.q, want.q) and np.array_equal(t.n, want.n)
    assert np.array_equal(t.eps, want.eps)
    assert not callable(t._q) and t.q is t.q  # read once, kept
    assert [p.to_dict() for p in back.pieces] == [p.to_dict() for p in dec.pieces]


def test_a_truncated_sample_column_is_one_error_line(stored, tmp_path):
    _, path = stored
    bad = _widened(path, tmp_path / "bad")
    f = bad / "part-00001" / "pieces.npz"
    with np.load(f) as z:
        cols = {k: z[k] for k in z.files}
    with zipfile.ZipFile(f, "w") as zf:  # the samples' member cut short
        for k, v in cols.items():
            with zf.open(k + ".npy", "w") as out:
                data = v.tobytes() if k != "q" else b"\x93NUMPY"
                if k != "q":
                    np.lib.format.write_array(out, v)
                else:
                    out.write(data)
    back = S.read_decomposition(bad)  # q is not read yet
    with pytest.raises(S.InvalidParameterError, match="cannot be read"):
        _ = back.pieces._table.q
