"""The tiles' workers and noding (tether/decomposition/tiles.py, issue 25): tether's own
worker processes shut down once the last tile task (a pieces task) has returned (a caller's
executor left alone), every task's freed memory returned before its result is sent, and
``noding="snap"`` (snap rounding from the start) giving the untiled snap-rounded noding's
parts bit for bit and, tiled, the untiled ``noding="snap"`` decomposition up to renumbering."""

from __future__ import annotations

from concurrent.futures import Executor, Future

import numpy as np
import pytest
import shapely
from renumbering import assert_equal_up_to_renumbering
from shapely.errors import GEOSException

import tether.curves.tasks as curve_tasks
import tether.decomposition.pipeline as pipeline
import tether.decomposition.tiles as tiles_mod
from tether.curves import REL_CURVE_TOL, critical_curves
from tether.decomposition import decompose
from tether.decomposition.arrangement import arrangement
from tether.decomposition.noding import SNAP_GRIDS, check_noding, node_lines
from tether.decomposition.tiles import tiled_noder
from tether.errors import InvalidParameterError
from tether.examples import load as load_example


def _fail(*args, **kwargs):
    raise GEOSException("TopologyException: Iterated noding failed to converge")


def _wkb(parts):
    """The parts as sorted WKB: equal lists are the same parts bit for bit."""
    return sorted(shapely.to_wkb(np.asarray(parts, dtype=object)))


class _Recorder(Executor):
    """Runs each task at once in this thread, recording the tasks and the shutdown."""

    def __init__(self, events):
        self.events = events

    def submit(self, fn, /, *args, **kwargs):
        self.events.append(("task", fn, args[0] if args else None))
        f = Future()
        f.set_result(fn(*args, **kwargs))
        return f

    def shutdown(self, wait=True, *, cancel_futures=False):
        self.events.append(("shutdown",))


def _stages(events):
    return lambda stage, frac: events.append(("stage", stage.split(" (")[0]))


def test_own_workers_shut_down_after_the_last_tile_task(monkeypatch):
    """The executor decompose makes is shut down once the pieces' tasks, the last ones,
    have returned: after every tile task, before the result is made; the pieces' tasks run
    after the regions."""
    events = []
    monkeypatch.setattr(pipeline, "process_executor", lambda: _Recorder(events))
    env = load_example("rectangle")
    decompose(env, 0.3 * env.diameter, progress=_stages(events), tiles=(2, 2))
    kinds = [e[0] if e[0] != "stage" else e[1] for e in events]
    down = kinds.index("shutdown")
    assert "task" in kinds[:down] and "task" not in kinds[down:]
    assert kinds[down + 1] == "done"
    # every task goes through trimmed: its freed memory returned before its result is sent
    # the critical intervals' tasks (tether.curves.tasks) return their memory themselves
    tasks = [e for e in events if e[0] == "task" and e[1] is not curve_tasks._chunk_intervals]
    assert {e[1] for e in tasks} == {tiles_mod.trimmed}
    assert {e[2] for e in tasks} == {tiles_mod.node_tile, tiles_mod.trace_tile,
                                     tiles_mod.pieces_tile}
    first_piece_task = next(i for i, e in enumerate(events) if e[0] == "task"
                            and e[2] is tiles_mod.pieces_tile)
    assert ("stage", "pieces") in events[:first_piece_task]
    assert all(e[2] is tiles_mod.pieces_tile for e in events[first_piece_task:]
               if e[0] == "task")


@pytest.mark.slow
def test_callers_executor_left_running():
    events = []
    env = load_example("rectangle")
    decompose(env, 0.3 * env.diameter, tiles=(2, 2), executor=_Recorder(events))
    assert ("shutdown",) not in events and events


def test_trimmed_returns_the_tasks_result(monkeypatch):
    calls = []
    monkeypatch.setattr(tiles_mod, "release_memory", lambda: calls.append("trim"))
    assert tiles_mod.trimmed(divmod, 7, 3) == (2, 1) and calls == ["trim"]


def test_noding_checked():
    assert check_noding("snap") == "snap"
    env = load_example("rectangle")
    with pytest.raises(InvalidParameterError, match="noding must be one of auto, snap"):
        decompose(env, 1.0, noding="fast")


@pytest.mark.slow
def test_snap_from_the_start_parts_bit_for_bit(monkeypatch):
    """``noding="snap"``: no floating-point task runs, and the tiles deliver the parts of the
    untiled ``noding="snap"`` (= the untiled noding where the floating-point noder fails)."""
    env = load_example("rectangle")
    inner, lss = env.internal, 0.3 * env.diameter * env.frame.scale
    tol = REL_CURVE_TOL * inner.diameter
    curves = critical_curves(inner, lss)
    floats = []
    real = tiles_mod.node_floating
    monkeypatch.setattr(tiles_mod, "node_floating", lambda lines: floats.append(1) or
                        real(lines))
    log = {}
    tiled = arrangement(inner, curves, tol, tiled_noder((3, 3), _Recorder([]), tol, log=log,
                                                        arcs=(inner, lss), noding="snap"))
    assert not floats and not log["float_failed"] and log["grid"] == SNAP_GRIDS[0] * tol
    whole = arrangement(inner, curves, tol, noding="snap")
    assert whole.grid == tiled.grid == SNAP_GRIDS[0] * tol
    assert _wkb(tiled.parts.lines()) == _wkb(whole.parts)
    assert (dict(zip(shapely.to_wkb(whole.parts), whole.part_sources, strict=True))
            == dict(zip(shapely.to_wkb(tiled.parts.lines()), tiled.part_sources, strict=True)))
    with monkeypatch.context() as mp:  # the untiled snap: the float-failing fallback's parts
        mp.setattr(shapely, "node", _fail)
        lines = np.asarray(whole.parts, dtype=object)
        assert _wkb(node_lines(lines, tol)[0]) == _wkb(node_lines(lines, tol,
                                                                  noding="snap")[0])


@pytest.mark.slow
def test_snap_from_the_start_decomposition_equal():
    env = load_example("convex_corner")
    lss = 0.3 * env.diameter
    whole = decompose(env, lss, noding="snap")
    tiled = decompose(env, lss, tiles=(4, 3), executor=_Recorder([]), noding="snap")
    assert_equal_up_to_renumbering(whole, tiled)
