"""Benchmark: the CPU time of each noding and face task of a floor plan's tiled arrangement,
and the wall time two workers would take over them.

Run: ``PYTHONPATH=src python benchmarks/bench_tiles.py [--size 1000] [--noding snap]
[--tiles auto]``. ``floor_plan(n, seed=0)``, ``lss = width / 15`` (``bench_scale.py``'s rule),
decomposed with ``tiles`` on an executor that runs each task in this process as it is
submitted and measures it (``time.process_time``), stopped once the arrangement's faces are
traced (nothing after the face tiles runs). Prints, for the noding tasks (``tiles``) and the
face tasks (``faces``): the tasks (first round and retries), the input sent (segments or
parts), the total, largest and median CPU seconds a task, and the wall time of 2 workers
over the measured times, scheduled as ``tiles.py`` submits them: ``rounds`` (the tasks of a
round in tile order, a retry round only once the whole round has ended: before this
benchmark's commit) and ``as ended`` (the largest tasks of the first round first, each retry
submitted as its task ends: :func:`tether.decomposition.tiles._rounds`). The main process's
own work between the tasks is not counted.
"""

from __future__ import annotations

import argparse
import heapq
import time
from concurrent.futures import Executor, Future

import numpy as np


class _Stop(Exception):
    """Ends the decomposition once the arrangement's noder has returned."""


class TimingExecutor(Executor):
    """Runs each task at once in this process and records its ``kind`` (the task's
    function), ``size`` (its first argument's length: the runs' vertices or the parts'
    points), ``cpu`` (CPU s), ``level`` (its round: 0 first, then one more a retry) and
    ``tile`` (a first-round task's ``own[1]``; its trust box is its tile's first ``done``
    region, the same object in the tile's retries)."""

    def __init__(self) -> None:
        self.tasks: list[dict] = []
        self.tile_of: dict[int, int] = {}

    def submit(self, fn, /, *args, **kwargs):  # noqa: ANN001, D102 (Executor's)
        task, rest = args[0], args[1:]
        t0 = time.process_time()
        f: Future = Future()
        f.set_result(fn(*args, **kwargs))
        trust, own, done = (rest[2], rest[4], rest[5]) if task.__name__ == "trace_tile" \
            else (rest[3], rest[5], rest[6])
        if not done:  # a first-round task: own is (grid, tile)
            self.tile_of[id(trust)] = own[1]
        tile = self.tile_of[id(done[0] if done else trust)]
        self.tasks.append({"kind": task.__name__, "size": len(rest[0]), "level": len(done),
                           "cpu": time.process_time() - t0, "tile": tile})
        return f


def _schedule(cpu: list[float], level: list[int], tile: list[int], ahead: bool,
              workers: int = 2) -> float:
    """The wall time (s) of ``workers`` over tasks of CPU times ``cpu``, each of a round
    ``level`` of a ``tile``: with ``ahead``, the first round largest first and a retry
    submitted as its tile's previous task ends; else round after round in tile order."""
    free = [0.0] * workers
    heapq.heapify(free)
    ends: dict[tuple[int, int], float] = {}
    order = sorted(range(len(cpu)), key=lambda i: (level[i], tile[i]))
    if ahead:
        first = [i for i in order if level[i] == 0]
        first.sort(key=lambda i: -cpu[i])
        order = first + [i for i in order if level[i] > 0]
    barrier = 0.0
    for lv in sorted(set(level)):
        if not ahead and lv > 0:
            barrier = max(ends.values())
        for i in (j for j in order if level[j] == lv):
            ready = ends.get((lv - 1, tile[i]), 0.0) if ahead else barrier
            start = max(heapq.heappop(free), ready)
            ends[lv, tile[i]] = start + cpu[i]
            heapq.heappush(free, start + cpu[i])
    return max(ends.values()) if ends else 0.0


def _table(name: str, tasks: list[dict]) -> str:
    """One row: the stage's tasks, CPU and the scheduled walls."""
    if not tasks:
        return f"{name:>6} {0:>6}"
    cpu = [t["cpu"] for t in tasks]
    level = [t["level"] for t in tasks]
    tile = [t["tile"] for t in tasks]
    first = sum(1 for v in level if v == 0)
    return (f"{name:>6} {first:>6} {len(tasks) - first:>7} {sum(t['size'] for t in tasks):>11,}"
            f" {sum(cpu):>9.1f} {max(cpu):>7.2f} {float(np.median(cpu)):>7.2f}"
            f" {_schedule(cpu, level, tile, False):>9.1f}"
            f" {_schedule(cpu, level, tile, True):>9.1f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=1000)
    ap.add_argument("--noding", choices=("auto", "snap"), default="snap")
    ap.add_argument("--tiles", default="auto", help="NXxNY or auto")
    args = ap.parse_args()
    import tether.decomposition.pipeline as pipeline
    from tether.decomposition import decompose
    from tether.decomposition.tiles import check_tiles
    from tether.examples.floorplan import floor_plan

    log: dict = {}
    made = pipeline.tiled_noder

    def stopping(tiles, executor, tol, progress=None, _log=None, **kw):  # noqa: ANN001
        inner = made(tiles, executor, tol, progress, log, **kw)

        def noder(*a):  # noqa: ANN002
            inner(*a)
            raise _Stop

        return noder

    pipeline.tiled_noder = stopping
    env = floor_plan(args.size, seed=0)
    lss = (env.bounds[2] - env.bounds[0]) / 15
    ex = TimingExecutor()
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        decompose(env, lss, tiles=check_tiles(args.tiles), executor=ex, noding=args.noding)
    except _Stop:
        pass
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    print(f"floor_plan({args.size}), noding {args.noding}: tiles {log.get('tiles')}, face "
          f"tiles {log.get('face_tiles')}; {wall:.1f} s wall, {cpu:.1f} s CPU in all")
    print(f"{'stage':>6} {'tasks':>6} {'retries':>7} {'sent':>11} {'CPU s':>9} {'max':>7}"
          f" {'median':>7} {'rounds':>9} {'as ended':>9}")
    print(_table("tiles", [t for t in ex.tasks if t["kind"] == "node_tile"]))
    print(_table("faces", [t for t in ex.tasks if t["kind"] == "trace_tile"]))


if __name__ == "__main__":
    main()
