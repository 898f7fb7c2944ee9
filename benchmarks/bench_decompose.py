"""Benchmark: decomposition of the paper's examples and of seeded floor plans.

Run: ``python benchmarks/bench_decompose.py [--max-vertices N]``. Prints a table. Goals
(issue 3): each paper example under 1 s; a 100-vertex plan under 10 s, growth close to linear
in the number of feature pairs within reach. The graph and elimination columns (issue 4) give
their time and its share of the decomposition's.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from tether import load_map
from tether.cli import example_path
from tether.decomposition import decompose
from tether.floorplan import floor_plan


def pairs_within_reach(env, lss: float) -> int:
    """Feature pairs (vertex, edge) within lss of each other: the size driver."""
    pidx, eidx = env.edge_index(lss).query(env.vertices)
    A, B, _, _ = env.oriented_edges
    p = env.vertices[pidx]
    a, b = A[eidx], B[eidx]
    d = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, d) / np.einsum("ij,ij->i", d, d), 0, 1)
    return int(np.sum(np.hypot(*(a + t[:, None] * d - p).T) < lss))


def timed(fn):
    t = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t


def row(name, env, lss):
    dec, t = timed(lambda: decompose(env, lss))
    cells = f"{name:<18}{env.n:>6}{pairs_within_reach(env, lss):>8}{lss:>6.2f}{t:>9.2f}"
    cells += f"{len(dec.curves):>8}{len(dec.regions):>9}{len(dec.cells):>7}{len(dec.pieces):>8}"
    try:
        from tether.escape import analyze
        from tether.graph import build_graph
    except ImportError:
        return cells
    (graph, verdict), tg = timed(lambda: (lambda g: (g, analyze(dec, g)))(build_graph(dec)))
    return cells + f"{tg:>8.2f}{100 * tg / t:>7.1f}%"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--max-vertices", type=int, default=400)
    args = ap.parse_args()
    print(f"{'map':<18}{'verts':>6}{'pairs':>8}{'lss':>6}{'time s':>9}{'curves':>8}"
          f"{'regions':>9}{'cells':>7}{'pieces':>8}{'graph s':>8}{'share':>8}")
    for name, lss in (("rectangle", 1.0), ("convex_corner", 1.0), ("nonconvex_corner", 1.0)):
        decompose(load_map(example_path(name)), lss)  # warm-up (imports, caches)
        print(row(name, load_map(example_path(name)), lss))
    for n in (25, 50, 100, 200, 400):
        if n > args.max_vertices:
            break
        env = floor_plan(n, seed=0)
        lss = (env.bounds[2] - env.bounds[0]) / 15
        print(row(env.name, env, lss), flush=True)


if __name__ == "__main__":
    main()
