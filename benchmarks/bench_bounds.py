"""Benchmark: distance_bound on 1,000,000 angle pairs, and one evaluation of each motion law.

Run: ``python benchmarks/bench_bounds.py``. Goals (issue 5): under 0.5 s for the million pairs,
under 20 µs per law evaluation.
"""

from __future__ import annotations

import time
import timeit

import numpy as np

from tether import motion
from tether.bounds import distance_bound


def main() -> None:
    rng = np.random.default_rng(0)
    th0 = rng.uniform(-10, 10, 1_000_000)
    thf = th0 + rng.uniform(-10, 10, 1_000_000)
    distance_bound(th0[:10], thf[:10], 1.0, 2.0, 1.0)
    best = min(
        (lambda t: (distance_bound(th0, thf, 1.0, 2.0, 1.0), time.perf_counter() - t)[1])(
            time.perf_counter())
        for _ in range(3)
    )
    print(f"{'task':<42}{'time':>12}")
    print(f"{'distance_bound, 1,000,000 angle pairs':<42}{best:>10.3f} s")
    T, O, V, W = (0.0, 0.0), (0.6, 0.8), (0.3, -0.9), (0.2, 0.4)
    laws = {
        "translate": lambda: motion.translate(T, O, V, 2.0),
        "follow": lambda: motion.follow(T, O, V, 2.0),
        "rotate": lambda: motion.rotate(T, O, V, 2.0, 1),
        "slide_on_wall": lambda: motion.slide_on_wall(T, O, V, (1.0, 0.0), 2.0),
        "contact_vertex": lambda: motion.contact_vertex(T, O, V, W, 2.0),
    }
    for name, fn in laws.items():
        n = 200_000
        t = min(timeit.repeat(fn, number=n, repeat=3)) / n
        print(f"{'one evaluation of ' + name:<42}{t * 1e6:>9.2f} µs")


if __name__ == "__main__":
    main()
