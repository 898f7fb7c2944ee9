"""Element-wise shapely calls in threads (tether._util.threads): the same results, in order."""

import numpy as np
import pytest
import shapely

from tether._util.threads import MIN_CHUNKED, THREADS_ENV, map_chunks, thread_count


def _slivers(n: int, seed: int = 0) -> np.ndarray:
    """Thin random quadrilaterals of varied size and angle (the costly case of the inscribed
    circle), some far from the origin."""
    rng = np.random.default_rng(seed)
    polys = []
    for _ in range(n):
        c = rng.uniform(-1e3, 1e3, 2)
        a = rng.uniform(0, np.pi)
        length, width = rng.uniform(0.5, 5), rng.uniform(1e-3, 0.3)
        u, v = np.array([np.cos(a), np.sin(a)]), np.array([-np.sin(a), np.cos(a)])
        skew = rng.uniform(0.2, 0.8)
        pts = [c, c + length * u, c + length * u + width * v, c + skew * length * u + width * v]
        polys.append(shapely.Polygon(pts))
    return np.array(polys, dtype=object)


@pytest.mark.parametrize("threads", ["1", "2", "3", "7"])
def test_chunks_give_the_direct_result_in_order(monkeypatch, threads):
    monkeypatch.setenv(THREADS_ENV, threads)
    faces = _slivers(3 * MIN_CHUNKED + 5)
    direct = shapely.maximum_inscribed_circle(faces, tolerance=1e-3)
    got = map_chunks(shapely.maximum_inscribed_circle, faces, tolerance=1e-3)
    assert len(got) == len(faces)
    assert all(shapely.equals_exact(direct, got, tolerance=0))
    # and element-wise functions of other shapes
    assert np.array_equal(map_chunks(shapely.area, faces), shapely.area(faces))


def test_short_arrays_and_empty(monkeypatch):
    monkeypatch.setenv(THREADS_ENV, "4")
    faces = _slivers(5)
    assert np.array_equal(map_chunks(shapely.area, faces), shapely.area(faces))
    assert len(map_chunks(shapely.area, faces[:0])) == 0


@pytest.mark.parametrize("value, expected", [("1", 1), ("6", 6), (" 3 ", 3)])
def test_thread_count_from_the_environment(monkeypatch, value, expected):
    monkeypatch.setenv(THREADS_ENV, value)
    assert thread_count() == expected


@pytest.mark.parametrize("value", ["", "0", "-2", "many", "1.5"])
def test_thread_count_ignores_what_is_not_a_positive_integer(monkeypatch, value):
    monkeypatch.setenv(THREADS_ENV, value)
    assert thread_count() >= 1
    import os
    assert thread_count() == len(os.sched_getaffinity(0))  # the cores this process may use


def test_single_threaded_keeps_a_users_setting(monkeypatch):
    from tether._util.threads import single_threaded

    monkeypatch.delenv(THREADS_ENV, raising=False)
    single_threaded()
    assert thread_count() == 1
    monkeypatch.setenv(THREADS_ENV, "3")
    single_threaded()
    assert thread_count() == 3


@pytest.mark.parametrize("threads", ["1", "2", "5"])
@pytest.mark.parametrize("count, batch", [(0, 3), (1, 3), (7, 3), (9, 3), (10, 100)])
def test_map_batches_in_order(monkeypatch, threads, count, batch):
    import threading

    from tether._util.threads import map_batches
    monkeypatch.setenv(THREADS_ENV, threads)
    seen = set()

    def span(lo, hi):
        seen.add(threading.get_ident())
        return (lo, hi)

    got = map_batches(span, count, batch)
    assert got == [(lo, min(lo + batch, count)) for lo in range(0, count, batch)]
    if threads == "1" or len(got) <= 2:  # one thread, or one batch after the first
        assert seen <= {threading.get_ident()}


def _summary(dec, verdict):
    """Everything a decomposition and its analysis report, as plain values."""
    g = verdict.graph
    return (dec.counts,
            [(r.cells, r.area, r.point, sorted(r.structure)) for r in dec.regions],
            [(p.regions, p.kind, p.features, p.sample, p.normal, p.eps, p.verified)
             for p in dec.pieces],
            [a.tolist() for a in (g.edge_a, g.edge_b, g.edge_piece)],
            verdict.strategy_exists, sorted(verdict.surviving))


@pytest.mark.slow
def test_batches_in_threads_give_the_single_threaded_decomposition(monkeypatch):
    """Small batches, so that a small map's free arcs, rod tests and clearances run in many
    batches in threads: every result equals that of one thread, exactly."""
    import tether.arcs as arcs
    import tether.decomposition as decomposition
    from tether.analysis import analyze
    from tether.decomposition import pieces
    from tether.examples.floorplan import floor_plan
    monkeypatch.setattr(arcs.free, "POINT_BATCH", 300)
    monkeypatch.setattr(pieces, "ACROSS_BATCH", 200)
    monkeypatch.setattr(pieces, "CLEARANCE_BATCH", 250)
    env = floor_plan(30, seed=2)
    lss = (env.bounds[2] - env.bounds[0]) / 10
    got = {}
    for threads in ("1", "3"):
        monkeypatch.setenv(THREADS_ENV, threads)
        dec = decomposition.decompose(env, lss)
        got[threads] = _summary(dec, analyze(dec))
    assert got["1"][0]["pieces"] > 100  # many batches of each kind
    assert got["1"] == got["3"]


@pytest.mark.parametrize("threads", ["1", "2"])
def test_in_background_gives_the_value_once_or_raises(monkeypatch, threads):
    import threading

    from tether._util.threads import in_background
    monkeypatch.setenv(THREADS_ENV, threads)
    ran_in = []

    def work(a, b):
        ran_in.append(threading.get_ident())
        return a + b

    get = in_background(work, 2, 3)
    assert get() == 5 and get() == 5
    assert len(ran_in) == 1  # computed once, however often asked
    if threads == "2":
        assert ran_in[0] != threading.get_ident()  # in a thread of its own
    else:
        assert ran_in[0] == threading.get_ident()  # inline, when first asked
    failing = in_background(lambda: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        failing()


def test_prepared_grid_blocks_are_those_of_a_query():
    """The blocks built ahead (as while GEOS nodes) are the ones the query then uses, built once."""
    from tether.spatial import SegmentGrid
    rng = np.random.default_rng(4)
    a = rng.uniform(0, 10, (500, 2))
    b = a + rng.normal(0, 0.3, (500, 2))
    grid = SegmentGrid(a, b)
    reach = 0.05
    made = grid.prepare(reach)
    pts = rng.uniform(0, 10, (200, 2))
    got = grid.meeting(pts - reach, pts + reach)
    want = SegmentGrid(a, b).meeting(pts - reach, pts + reach)  # blocks built by the query
    assert all(np.array_equal(x, y) for x, y in zip(got, want, strict=True))
    assert len(got[0]) > 0
    assert list(grid._blocks.values()) == [made]  # the query found the prepared blocks
