"""Benchmark: a 10 x 10 square with k collinear vertices on its bottom wall, lss = 3.

Run: ``python benchmarks/bench_collinear.py [k ...]`` (default k = 0, 1, 10, 50, 100, 200,
400). Prints regions, cells, pieces, straight vertices and the time of decompose + G + verdict.
A straight vertex is no feature of the free space: every row should show the plain square's
13 regions (issue 9: before, 100 vertices gave thousands of regions in seconds and 400 gave
51,608 regions in over four minutes). Times are single runs on a shared machine: noisy.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from tether import Environment
from tether.analysis import analyze, build_graph
from tether.decomposition import decompose


def square_with(k: int) -> Environment:
    """The square with ``k`` vertices evenly spaced along its bottom edge."""
    xs = np.linspace(0.0, 10.0, k + 2)[1:-1]
    bottom = np.column_stack((xs, np.zeros(k)))
    return Environment(np.vstack(([[0.0, 0.0]], bottom, [[10, 0], [10, 10], [0, 10]])), (),
                       f"square+{k}")


def main(ks: list[int]) -> None:
    print(f"{'k':>5}{'vertices':>10}{'straight':>10}{'regions':>9}{'cells':>7}{'pieces':>8}"
          f"{'G edges':>9}{'time (s)':>10}")
    for k in ks:
        env = square_with(k)
        t = time.perf_counter()
        dec = decompose(env, 3.0)
        g = build_graph(dec)
        analyze(dec, g)
        dt = time.perf_counter() - t
        straight = int(getattr(env, "straight", np.zeros(0)).sum())
        print(f"{k:>5}{env.n:>10}{straight:>10}{len(dec.regions):>9}{len(dec.cells):>7}"
              f"{len(dec.pieces):>8}{len(g.edge_list):>9}{dt:>10.3f}")


if __name__ == "__main__":
    main([int(a) for a in sys.argv[1:]] or [0, 1, 10, 50, 100, 200, 400])
