"""Sweeps over lss: rows, intervals refined by bisection against a direct scan, executors
(threads, processes, Dask), the kernel hook, formats and the CLI."""

from __future__ import annotations

import json
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import numpy as np
import pytest

from tether.analysis import analyze
from tether.cli import main
from tether.decomposition import decompose
from tether.environment import Environment
from tether.errors import InvalidParameterError
from tether.examples import path as example_path
from tether.io import load_map, save_map
from tether.io.ros import rasterize
from tether.sweep import evaluate, parse_lss_range, sweep

RECT = load_map(example_path("rectangle"))  # 1.5 x 3: a strategy at 0.5, none at 1.0


def direct(env: Environment, lss: float) -> bool:
    return analyze(decompose(env, lss)).strategy_exists


def test_parse_lss_range():
    assert parse_lss_range("0.5:3:0.5") == [0.5, 1.0, 1.5, 2.0, 2.5, 3.0]
    assert len(parse_lss_range("0.5:3:0.1")) == 26
    assert parse_lss_range("1, 2,0.5") == [1.0, 2.0, 0.5]
    assert parse_lss_range("2") == [2.0]
    for bad in ("a:b:c", "1:2", "1:2:0", "2:1:0.1", "0:1e9:1e-3"):
        with pytest.raises(InvalidParameterError):
            parse_lss_range(bad)


@pytest.mark.slow
def test_sweep_rows_and_bisection_match_a_direct_scan():
    res = sweep(RECT, [0.25, 0.5, 1.0, 1.5], tol=0.02)
    for row in res.rows:
        assert row.error is None and row.verified is not False
        assert row.strategy_exists == direct(RECT, row.lss)
    assert len(res.intervals) == 1
    iv = res.intervals[0]
    assert iv.lo == 0.25 and iv.below is None
    assert iv.above - iv.hi <= 0.02
    assert 0.5 <= iv.hi < 1.0
    # known independently (docs/rectangle_sweep.md): a rectangle has a strategy iff both sides
    # are at least 2 lss, so this 1.5-wide one up to lss 0.75 exactly
    assert iv.hi <= 0.75 + 1e-9 < iv.above + 2e-9
    # a dense direct scan agrees: a strategy up to hi, none from above to 1.0
    for lss in np.linspace(0.5, iv.hi, 4):
        assert direct(RECT, lss)
    for lss in np.linspace(iv.above, 1.0, 4):
        assert not direct(RECT, lss)
    assert res.longest == iv.hi
    assert [r.lss for r in res.rows] == sorted(r.lss for r in res.rows)
    assert sum(r.refined for r in res.rows) >= 5


@pytest.mark.slow
def test_sweep_intervals_contain_a_dense_scan():
    env = load_map(example_path("convex_corner"))
    res = sweep(env, np.arange(0.5, 3.01, 0.5), tol=0.01)
    dense = np.arange(0.5, 3.001, 0.05)
    for lss in dense:
        inside = any(iv.lo <= lss <= iv.hi for iv in res.intervals)
        between = any((iv.below or 0) < lss < iv.lo or iv.hi < lss < (iv.above or np.inf)
                      for iv in res.intervals)
        if not between:
            assert direct(env, lss) == inside, lss


def test_no_refinement_and_validation():
    res = sweep(RECT, [0.5, 1.0], tol=0)
    assert len(res.rows) == 2 and res.tol is None
    assert res.intervals[0].hi == 0.5 and res.intervals[0].above == 1.0
    with pytest.raises(InvalidParameterError):
        sweep(RECT, [])
    with pytest.raises(InvalidParameterError):
        sweep(RECT, [0.5, -1])
    with pytest.raises(InvalidParameterError):
        sweep(RECT, [0.5], vt=1.0)
    with pytest.raises(InvalidParameterError):
        sweep(RECT, [0.5], vt=2.0, vo=1.0)
    with pytest.raises(InvalidParameterError):
        sweep(RECT, [0.5], tol=-1)


def test_failure_is_a_row_not_an_exception():
    row = evaluate(RECT.to_dict(), float("nan"))
    assert row.strategy_exists is None and "InvalidParameterError" in row.error


def _same(a, b):
    assert [(r.lss, r.strategy_exists, r.counts) for r in a.rows] == \
        [(r.lss, r.strategy_exists, r.counts) for r in b.rows]
    assert a.intervals == b.intervals


@pytest.mark.slow
def test_executors_give_the_serial_result():
    serial = sweep(RECT, [0.5, 1.0], tol=0.1)
    with ThreadPoolExecutor(2) as ex:
        _same(serial, sweep(RECT, [0.5, 1.0], executor=ex, tol=0.1))
    with ProcessPoolExecutor(2) as ex:
        _same(serial, sweep(RECT, [0.5, 1.0], executor=ex, tol=0.1))


@pytest.mark.slow
def test_dask_executor():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        res = sweep(RECT, [0.5, 1.0], executor=client.get_executor(), tol=0.1)
    _same(sweep(RECT, [0.5, 1.0], tol=0.1), res)


@pytest.mark.slow
def test_kernel_hook_gives_the_kernels_safe_fraction():
    import tether.game as game

    res = sweep(RECT, [0.5], vt=1.0, vo=2.0, tol=0)
    direct = game.surveillance_kernel(RECT, 0.5, 1.0, 2.0).safe_fraction_total()
    assert res.rows[0].safe_fraction == pytest.approx(direct)


def test_kernel_hook_failure_keeps_the_verdict(monkeypatch):
    import tether.game as game

    assert all(r.safe_fraction is None for r in sweep(RECT, [0.5], tol=0).rows)

    def broken(env, lss, vt, vo):
        raise RuntimeError("no grid")

    monkeypatch.setattr(game, "surveillance_kernel", broken)
    row = sweep(RECT, [0.5], vt=1.0, vo=2.0, tol=0).rows[0]
    assert row.strategy_exists is True and row.error == "kernel: RuntimeError: no grid"


def test_formats():
    res = sweep(RECT, [0.5, 1.0], tol=0)
    d = json.loads(json.dumps(res.to_dict()))
    assert d["longest_lss_with_strategy"] == 0.5
    lines = res.to_csv().splitlines()
    assert lines[0].startswith("lss,strategy_exists,verified,regions")
    assert lines[1].startswith("0.5,true,true,") and lines[2].startswith("1.0,false,true,")


@pytest.mark.slow
def test_same_verdict_through_every_format(tmp_path):
    """JSON, GeoJSON, WKT and a rasterized ROS map (walls on the cell grid) agree."""
    env = Environment([[0, 0], [4, 0], [4, 2.5], [0, 2.5]],
                      ([[1.5, 1.0], [2.0, 1.0], [2.0, 1.5], [1.5, 1.5]],), "pillar")
    assert main(["convert", str(_save_json(env, tmp_path)), str(tmp_path / "m.geojson")]) == 0
    assert main(["convert", str(tmp_path / "m.json"), str(tmp_path / "m.wkt")]) == 0
    rasterize(env, 0.05, origin=(-0.1, -0.1)).save(tmp_path / "m.yaml")
    maps = [load_map(tmp_path / f"m{ext}") for ext in (".json", ".geojson", ".wkt", ".yaml")]
    for lss, expect in ((0.4, True), (1.2, False)):
        assert [direct(m, lss) for m in maps] == [expect] * 4, lss


def _save_json(env, tmp_path):
    save_map(env, tmp_path / "m.json")
    return tmp_path / "m.json"


@pytest.mark.slow
def test_sweep_cli(tmp_path, capsys):
    m = str(example_path("rectangle"))
    assert main(["sweep", m, "--lss", "0.5:1:0.5", "--tol", "0.1"]) == 0
    out = capsys.readouterr().out
    assert "longest lss with a strategy" in out and "strategy can exist for lss from 0.5" in out
    assert main(["sweep", m, "--lss", "0.5,1", "--tol", "0", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["longest_lss_with_strategy"] == 0.5
    assert main(["sweep", m, "--lss", "0.5,1", "--tol", "0", "--csv"]) == 0
    assert capsys.readouterr().out.startswith("lss,")
    plot = tmp_path / "s.png"
    assert main(["sweep", m, "--lss", "0.5,1", "--tol", "0", "--plot", str(plot),
                 "--workers", "1"]) == 0
    assert plot.stat().st_size > 0
    capsys.readouterr()
    for bad in (["--lss", "x"], ["--lss", "1", "--plot", str(tmp_path / "no" / "s.png")],
                ["--lss", "1", "--workers", "0"], ["--lss", "1", "--vt", "1"],
                ["--lss", "1", "--seed", "0", "0"]):
        assert main(["sweep", m, *bad]) == 2
    assert capsys.readouterr().err.count("error:") == 5


@pytest.mark.slow
def test_sweep_cli_unreachable_dask(capsys):
    assert main(["sweep", str(example_path("rectangle")), "--lss", "1",
                 "--dask", "tcp://127.0.0.1:9", "--dask-timeout", "1"]) == 2
    assert "Dask scheduler" in capsys.readouterr().err


@pytest.mark.slow
def test_sweep_cli_on_a_dask_cluster(capsys):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster:
        assert main(["sweep", str(example_path("rectangle")), "--lss", "0.5,1", "--tol", "0",
                     "--json", "--dask", cluster.scheduler_address]) == 0
    assert json.loads(capsys.readouterr().out)["longest_lss_with_strategy"] == 0.5
