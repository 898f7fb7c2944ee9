"""A decomposition holds its region polygons and piece lines packed as WKB (#25: no shapely
object a region or a piece), made when first read. Checked against the geometry itself: the
polygons tile the free space with the regions' areas, each piece's line lies on the boundary
of both its regions, and a store is written from the packed bytes without decoding them."""

import numpy as np
import pytest
import shapely

import tether.decomposition.store as S
from tether import Environment
from tether.decomposition import decompose
from tether.decomposition.views import (
    PackedFaces,
    Shapes,
    packed_geometries,
    wkb_column,
    wkb_geometries,
)

#: an L-shaped room with a straight vertex on its long wall (reported in the file's frame)
ELL = Environment([(0, 0), (2, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])


@pytest.fixture(scope="module")
def dec():
    return decompose(ELL, 0.7)


def _held_packed(dec) -> bool:
    shapes, lines = dec.regions._table.shapes, dec.pieces._table.shapes
    return (shapes._held is None and lines._held is None
            and type(shapes.held_unions()) in (PackedFaces, type(None)))


def test_fresh_decomposition_holds_no_geometry_and_reads_the_right_one():
    dec = decompose(ELL, 0.7)  # its own: read here
    assert _held_packed(dec)
    polys = np.array([r.polygon for r in dec.regions], dtype=object)
    area = np.array([r.area for r in dec.regions])
    assert np.allclose(shapely.area(polys), area, rtol=1e-9, atol=1e-12)
    assert abs(area.sum() - ELL.polygon.area) < 1e-9  # they tile the free space
    assert shapely.union_all(polys).symmetric_difference(ELL.polygon).area < 1e-9
    for p in dec.pieces:  # on the boundary of both its regions (map units)
        for r in p.regions:
            assert shapely.distance(polys[r].boundary,
                                    shapely.line_interpolate_point(p.geometry, 0.5,
                                                                   normalized=True)) < 1e-9


def test_packed_column_in_batches_is_the_column_at_once():
    geoms = np.array([shapely.box(i, 0, i + 1, 1 + i) for i in range(7)] + [None]
                     + [shapely.LineString([(0, 0), (i, 1)]) for i in range(1, 4)],
                     dtype=object)
    whole = wkb_column(geoms)
    for batch in (1, 2, 3, 100):
        raw, ptr = packed_geometries(lambda ids: geoms[ids], np.arange(len(geoms)), batch)
        assert raw.tobytes() == whole[0].tobytes() and ptr.tolist() == whole[1].tolist()
    back = wkb_geometries(*whole)
    assert back[7] is None and all(a.equals_exact(b, 0) for a, b in zip(
        np.delete(back, 7), np.delete(geoms, 7), strict=True))
    assert Shapes(None, wkb=whole).some(np.array([2]))[0].equals_exact(geoms[2], 0)
    faces = PackedFaces(np.array([1, 4]), np.array([0, 2, 5]), *wkb_column(geoms[:5]))
    assert [len(f) for _, f in faces.items()] == [2, 3] and 4 in faces and 2 not in faces
    count, raw, fptr = faces.held_wkb(2, 5)
    assert count.tolist() == [0, 0, 3] and wkb_geometries(raw, fptr)[0].equals_exact(
        geoms[2], 0)


def test_store_written_from_the_packed_bytes(dec, tmp_path, monkeypatch):
    encoded = []
    real = S._wkb
    monkeypatch.setattr(S, "_wkb", lambda g: encoded.append(len(g)) or real(g))
    path = S.write_decomposition(dec, tmp_path / "s", parts=3)
    assert not any(encoded) and _held_packed(dec)  # nothing decoded nor encoded again
    back = S.read_decomposition(path)
    assert [r.polygon.wkb for r in back.regions] == [r.polygon.wkb for r in dec.regions]
    assert [p.geometry.wkb for p in back.pieces] == [p.geometry.wkb for p in dec.pieces]


def test_store_read_holds_no_arcs_and_reads_them_for_g(dec, tmp_path):
    """The crossings' arcs of a store are read when G is built, not held (at 4,000 map
    vertices ~1.6 GB): the same values as the decomposition's, the same G."""
    from tether.analysis import build_graph

    back = S.read_decomposition(S.write_decomposition(dec, tmp_path / "s", parts=3))
    assert callable(back._crossing_arcs)
    a, b = dec.crossing_arcs(), back.crossing_arcs()
    for name in ("point", "start", "end", "start_code", "end_code", "full"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
        assert getattr(a, name).dtype == getattr(b, name).dtype, name
    g, h = build_graph(dec), build_graph(back)
    for name in ("edge_a", "edge_b", "edge_piece", "partner_ptr", "partner_slot"):
        assert np.array_equal(getattr(g, name), getattr(h, name)), name
    assert callable(back._crossing_arcs) and "_found_arcs" not in vars(back)
