"""Benchmark: exact free arcs for 100,000 points and the rod test for 1,000,000 rods.

Run: ``python benchmarks/bench_arcs.py``. Prints a table; goals (issue 2): arcs for 100,000
points in a 100-vertex map under 1 s, ``rod_is_free`` for 1,000,000 (point, angle) pairs
under 1 s. Times are the best of 3 runs, after one warm-up (which builds the edge index).
"""

from __future__ import annotations

import time

import numpy as np

from tether import free_arcs_many, rod_is_free_many
from tether.examples.floorplan import floor_plan


def interior(env, m, rng):
    x0, y0, x1, y1 = env.bounds
    out = np.zeros((0, 2))
    while len(out) < m:
        p = rng.uniform([x0, y0], [x1, y1], size=(2 * m, 2))
        out = np.vstack((out, p[env.contains(p[:, 0], p[:, 1])]))
    return out[:m]


def best(fn, reps=3):
    fn()
    times = []
    for _ in range(reps):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def main() -> None:
    rng = np.random.default_rng(0)
    print(f"{'map':<14}{'vertices':>9}{'lss':>7}{'task':>34}{'time (s)':>10}")
    for n in (100, 400):
        env = floor_plan(n, seed=0)
        lss = (env.bounds[2] - env.bounds[0]) / 15
        pts = interior(env, 100_000, rng)
        t = best(lambda env=env, pts=pts, lss=lss: free_arcs_many(env, pts, lss, check=False))
        print(f"{env.name:<14}{env.n:>9}{lss:>7.2f}{'free arcs, 100,000 points':>34}{t:>10.3f}")
        t = best(lambda env=env, pts=pts, lss=lss: free_arcs_many(env, pts, lss))
        print(f"{env.name:<14}{env.n:>9}{lss:>7.2f}{'same, with the inside check':>34}{t:>10.3f}")
        rods = interior(env, 1_000_000, rng)
        ang = rng.uniform(0, 2 * np.pi, len(rods))
        t = best(lambda env=env, rods=rods, ang=ang, lss=lss: rod_is_free_many(env, rods, ang, lss))
        print(f"{env.name:<14}{env.n:>9}{lss:>7.2f}{'rod_is_free, 1,000,000 rods':>34}{t:>10.3f}")


if __name__ == "__main__":
    main()
