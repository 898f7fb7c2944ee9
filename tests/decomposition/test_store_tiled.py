"""A store written tile by tile (``decompose(..., tiles=..., out=DIR)``, issue 25): each
tile's pieces and crossing arcs in a part of their own, the index last; read back it is the
in-memory tiled decomposition column for column, ``tether analyze --from DIR`` gives the
in-memory run's verdict and counts, and a failure part-way leaves nothing (an earlier store
in place)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import SerialExecutor

import tether.decomposition.store as S
from tether.analysis import analyze
from tether.cli import main
from tether.decomposition import decompose
from tether.errors import OutputPathError
from tether.examples import load as load_example
from tether.examples import path as example_path


def _same(a, b):
    """Every column of two decompositions equal (pieces in order, their lines, the arcs at
    their crossings, regions, cells, counts)."""
    assert repr(a) == repr(b) and a.counts == b.counts
    assert a.to_dict(geometry=True) == b.to_dict(geometry=True)
    assert (a.unresolved_pieces, a.unresolved_longest) == (b.unresolved_pieces,
                                                           b.unresolved_longest)
    assert list(a.pieces) == list(b.pieces)
    assert all(p.geometry.equals_exact(q.geometry, 0) for p, q in zip(a.pieces, b.pieces,
                                                                      strict=True))
    ta, tb = a.crossing_arcs(), b.crossing_arcs()
    for f in ("point", "start", "end", "start_code", "end_code", "full"):
        assert np.array_equal(getattr(ta, f), getattr(tb, f)), f
    for x, y in zip(a.cell_codes(), b.cell_codes(), strict=True):
        assert np.array_equal(x, y)


@pytest.mark.slow
@pytest.mark.parametrize("name,tiles", [("rectangle", (4, 4)), ("gallery", (5, 5))])
def test_written_tile_by_tile_reads_back_as_the_tiled_run(tmp_path, name, tiles):
    env = load_example(name)
    lss = 0.3 * env.diameter if name != "gallery" else 1.0
    mem = decompose(env, lss, tiles=tiles, executor=SerialExecutor())
    back = decompose(env, lss, tiles=tiles, executor=SerialExecutor(), out=tmp_path / "s")
    _same(mem, back)
    index = json.loads((tmp_path / "s" / "index.json").read_text())
    assert index["version"] == S.VERSION == 2
    parts = index["parts"]
    assert len(parts) > 3  # the first (regions, cells, curves), then one per pieces task
    assert parts[0]["rows"]["pieces"] == [0, 0]
    assert all(p["rows"]["regions"] == [0, 0] for p in parts[1:])
    sizes = [p["rows"]["pieces"][1] - p["rows"]["pieces"][0] for p in parts[1:]]
    assert min(sizes) > 0 and sum(sizes) == len(mem.pieces)
    assert analyze(back).to_dict() == analyze(mem).to_dict()  # the self-check included


@pytest.mark.slow
def test_cli_analyze_from_a_tiled_store(tmp_path, capsys):
    """``tether analyze --from DIR`` on a store written tile by tile: the verdict (its
    eliminations, pieces named alike) and counts of the same tiled run in memory."""
    gallery, store = str(example_path("gallery")), str(tmp_path / "s")
    tiling = ["--tiles", "6x6", "--workers", "2"]
    assert main(["decompose", gallery, "--lss", "1", *tiling, "--out", store]) == 0
    capsys.readouterr()
    assert main(["analyze", gallery, "--lss", "1", "--json", *tiling]) == 0
    mem = json.loads(capsys.readouterr().out)
    assert main(["analyze", "--from", store, "--json"]) == 0
    back = json.loads(capsys.readouterr().out)
    assert len(json.loads((tmp_path / "s" / "index.json").read_text())["parts"]) > 3
    assert back["verified"] and mem["verified"]
    for k in ("verdict", "counts", "edges"):
        assert back[k] == mem[k], k


@pytest.mark.slow
def test_failure_part_way_leaves_the_earlier_store(tmp_path, monkeypatch):
    env = load_example("rectangle")
    lss = 0.3 * env.diameter
    target = tmp_path / "s"
    first = decompose(env, lss, tiles=(4, 4), executor=SerialExecutor(), out=target)
    before = sorted(p.name for p in target.iterdir())
    real = S.PartWriter.pieces
    calls = []

    def failing(self, table, arcs):
        calls.append(1)
        if len(calls) == 2:
            raise OSError(28, "No space left on device")
        real(self, table, arcs)

    monkeypatch.setattr(S.PartWriter, "pieces", failing)
    with pytest.raises(OutputPathError, match="No space left"):
        decompose(env, 0.25 * env.diameter, tiles=(4, 4), executor=SerialExecutor(), out=target)
    assert sorted(p.name for p in target.iterdir()) == before
    assert [p.name for p in tmp_path.iterdir()] == ["s"]  # no temporary folder left
    _same(first, S.read_decomposition(target))
