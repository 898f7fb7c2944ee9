"""``analyze --json`` stays bounded on large maps (#25): a list longer than
``JSON_LIST_MAX`` (edges of G, surviving cells, eliminations) is given as its count and the
file of its columns (``--arrays FILE.npz``). The columns are read back into names
independently (codes and feature names) and compared with the verdict's own lists."""

import json
import math

import numpy as np
import pytest

import tether.analysis.elimination as E
from tether import Environment
from tether.analysis import analyze
from tether.cli import main
from tether.decomposition import decompose
from tether.examples import path as example_path

QUICK = {"self_check": False, "near_critical": False}
ROOM = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])  # every cell falls
ELL = Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])  # some survive


@pytest.fixture(scope="module", params=["room", "ell"])
def verdict(request):
    env, lss = (ROOM, 1.0) if request.param == "room" else (ELL, 0.5)
    return analyze(decompose(env, lss), **QUICK)


def _names(cols, which):
    names = cols["feature_names"].tolist()
    r, s, e = (cols[k][which] for k in ("cell_region", "cell_start", "cell_end"))
    return [f"(R{a},{names[b + 1]},{names[c + 1]})" for a, b, c in zip(
        r.tolist(), s.tolist(), e.tolist(), strict=True)]


def test_arrays_file_reads_back_as_the_verdicts_lists(verdict, tmp_path):
    path = verdict.save_arrays(tmp_path / "v.npz")
    with np.load(path, allow_pickle=False) as z:
        cols = {k: z[k] for k in z.files}
    a, b = _names(cols, cols["edge_a"]), _names(cols, cols["edge_b"])
    edges = sorted((min(x, y), max(x, y), f"P{k}") for x, y, k in zip(
        a, b, cols["edge_piece"].tolist(), strict=True))
    assert edges == verdict.graph.edges and len(edges) > 10
    assert sorted(_names(cols, cols["surviving"])) == sorted(verdict.surviving)
    el = verdict.eliminated
    assert _names(cols, cols["eliminated_cell"]) == [e.cell_name for e in el]
    assert cols["eliminated_piece"].tolist() == [e.piece for e in el]
    assert cols["eliminated_round"].tolist() == [e.round for e in el]
    because = [-1 if e.because is None else e.because for e in el]
    assert cols["eliminated_because"].tolist() == because


def test_lists_over_the_bound_become_counts(verdict):
    whole = verdict.to_dict()
    assert whole == verdict.to_dict(max_items=math.inf)  # small: under the bound, unchanged
    assert isinstance(whole["edges"], list) and len(whole["edges"]) == verdict.graph.n_edges
    few = verdict.to_dict(max_items=3, arrays="v.npz")
    assert few["edges"] == {"count": verdict.graph.n_edges, "arrays": "v.npz"}
    for key, n in (("surviving", len(verdict.surviving)),
                   ("eliminated", len(verdict.eliminated))):
        want = {"count": n, "arrays": "v.npz"} if n > 3 else whole["verdict"][key]
        assert few["verdict"][key] == want
    rest = {k: v for k, v in few.items() if k != "edges"}
    assert {k: v for k, v in whole.items() if k != "edges"}.keys() == rest.keys()
    assert few["counts"] == whole["counts"] and few["verdict"]["story"] == whole["verdict"][
        "story"]


@pytest.mark.slow
def test_cli_arrays_and_bounded_json(capsys, tmp_path, monkeypatch):
    out = tmp_path / "g.npz"
    argv = ["analyze", str(example_path("rectangle")), "--lss", "1", "--json"]
    assert main(argv) == 0
    plain = json.loads(capsys.readouterr().out)
    assert main([*argv, "--arrays", str(out)]) == 0
    assert json.loads(capsys.readouterr().out) == plain and out.exists()  # small: as before
    monkeypatch.setattr(E, "JSON_LIST_MAX", 5)
    assert main([*argv, "--arrays", str(out)]) == 0
    got = json.loads(capsys.readouterr().out)
    assert got["edges"] == {"count": plain["counts"]["edges"], "arrays": str(out)}
    with np.load(out) as z:
        assert len(z["edge_a"]) == plain["counts"]["edges"]
    assert main([*argv, "--arrays", str(tmp_path / "g.txt")]) == 2
    assert "extension" in capsys.readouterr().err
