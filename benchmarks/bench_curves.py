"""Benchmark: the critical curves of ``floor_plan(n, seed=0)`` (lss = width / 15) in one
process, then with their intervals made by tasks on worker processes
(:mod:`tether.curves.tasks`), and whether both give the same curves bit for bit.

Run: ``python benchmarks/bench_curves.py [VERTICES ...] [--workers N]`` (default 1000 2000,
2 workers). Prints a table: wall seconds, the main process's CPU seconds and the workers'
(their start included), the curves and their polyline vertices, and the load average at
the start of each row (the machine may be shared: compare CPU seconds).
"""

from __future__ import annotations

import argparse
import gc
import os
import resource
import time

import numpy as np

from tether.curves import critical_curves
from tether.decomposition.tiles import process_executor
from tether.examples.floorplan import floor_plan


def children_cpu() -> float:
    """CPU seconds of this process's ended children (the workers, once shut down)."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def timed(fn):
    """``fn()``, its wall and CPU seconds (this process)."""
    t, c = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - t, time.process_time() - c


def same_curves(a, b) -> bool:
    """Whether two lists of curves are equal, polylines and parameters bit for bit."""
    return len(a) == len(b) and all(
        (x.kind, x.features, x.intervals) == (y.kind, y.features, y.intervals)
        and len(x.polylines) == len(y.polylines)
        and all(np.array_equal(p, q) for p, q in zip(x.polylines + x.params,
                                                    y.polylines + y.params, strict=True))
        for x, y in zip(a, b, strict=True))


def row(n: int, workers: int) -> None:
    env = floor_plan(n, seed=0)
    inner = env.internal
    lss = (env.bounds[2] - env.bounds[0]) / 15 * env.frame.scale
    load = os.getloadavg()[0]
    whole, wall, cpu = timed(lambda: critical_curves(inner, lss))
    verts = sum(len(p) for c in whole for p in c.polylines)
    print(f"{n:>9,}{'1 process':>14}{load:>6.2f}{wall:>9.1f}{cpu:>9.1f}{'-':>9}"
          f"{len(whole):>9,}{verts:>12,}{'':>6}", flush=True)
    gc.collect()
    load = os.getloadavg()[0]
    before = children_cpu()
    pool = process_executor(workers)
    try:
        tasked, wall, cpu = timed(lambda: critical_curves(inner, lss, executor=pool))
    finally:
        pool.shutdown()
    same = "yes" if same_curves(tasked, whole) else "NO"
    verts = sum(len(p) for c in tasked for p in c.polylines)
    print(f"{n:>9,}{f'{workers} workers':>14}{load:>6.2f}{wall:>9.1f}{cpu:>9.1f}"
          f"{children_cpu() - before:>9.1f}{len(tasked):>9,}{verts:>12,}{same:>6}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("vertices", nargs="*", type=int, default=[1000, 2000])
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    print(f"{'vertices':>9}{'intervals':>14}{'load':>6}{'wall s':>9}{'main CPU':>9}"
          f"{'workers':>9}{'curves':>9}{'poly. verts':>12}{'same':>6}")
    for n in args.vertices:
        row(n, args.workers)


if __name__ == "__main__":
    main()
