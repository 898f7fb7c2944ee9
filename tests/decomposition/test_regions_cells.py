"""The cells made a run of regions at a time (#25: the rows' temporaries bounded) are each
region's structure's pairs, sorted by (start name, end name), one per pair (a FULL region:
one ``(-1, -1)`` cell), checked against the regions' structures one by one, whatever the
run length."""

import numpy as np
import pytest
from conftest import GENERIC, STAR_HOLE

import tether.decomposition.regions as R
from tether.arcs import feature_name
from tether.decomposition import decompose
from tether.decomposition.structure import FREE, Structure


def _cells_by_region(dec):
    """Each region's cells as ``(start, end)`` names, from its structure alone."""
    names = {}
    for r in dec.regions:
        st = r.structure
        if st == Structure.FULL:
            names[r.id] = [(FREE, FREE)]
        else:  # (start name, end name) pairs, sorted
            names[r.id] = sorted((feature_name(dec.env, a), feature_name(dec.env, b))
                                 for a, b in st)
    return names


@pytest.mark.slow
@pytest.mark.parametrize(("env", "lss", "chunk"), [(STAR_HOLE, 2.0, 1), (GENERIC, 3.0, 5)])
def test_cells_in_runs_are_the_structures_pairs(monkeypatch, env, lss, chunk):
    monkeypatch.setattr(R, "CELL_CHUNK", chunk)
    dec = decompose(env, lss)
    region, start, end = dec.cell_codes()
    assert np.all(np.diff(region) >= 0)  # region by region
    want = _cells_by_region(dec)
    got = {}
    for c in dec.cells:
        got.setdefault(c.region, []).append((c.start_feature, c.end_feature))
    assert {r: v for r, v in want.items() if v} == got
    monkeypatch.setattr(R, "CELL_CHUNK", 1 << 20)
    whole = decompose(env, lss).cell_codes()
    for x, y in zip((region, start, end), whole, strict=True):
        assert np.array_equal(x, y) and x.dtype == y.dtype
