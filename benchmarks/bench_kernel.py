"""Speed of the surveillance kernel (issue #11): gallery map, growth with the grid.

For each grid (``h`` = map size / N, ``n_a`` orientations) the table gives the setup time (free
mask from the exact arcs, and the continuations of every move, computed once), the iteration
time, iterations, states per second per iteration (``states × iterations / iteration time``)
and the total. The goal: N = 100, 180 orientations under 30 s. The machine is shared: times
are noisy (say so when quoting them).

Usage::

    python benchmarks/bench_kernel.py [--ratio 0.6] [--lss 1]
"""

from __future__ import annotations

import argparse
import time

from tether.examples import path as example_path
from tether.game import build_grid, surveillance_kernel
from tether.io import load_map


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ratio", type=float, default=0.6, help="vt/vo (vo = 1)")
    ap.add_argument("--lss", type=float, default=1.0)
    ap.add_argument("--grids", default="50:90,100:180,141:256",
                    help="comma-separated N:n_a (h = size/N)")
    args = ap.parse_args()
    env = load_map(example_path("gallery"))
    x0, y0, x1, y1 = env.bounds
    size = max(x1 - x0, y1 - y0)
    print(f"gallery, lss {args.lss:g}, vt/vo {args.ratio:g}, scheme inner, 8 directions")
    print(f"{'N':>5} {'n_a':>5} {'states':>10} {'free':>10} {'setup s':>8} {'iter s':>8} "
          f"{'iters':>6} {'states/s/iter':>14} {'total s':>8} {'safe %':>7}")
    for spec in args.grids.split(","):
        n, n_a = (int(x) for x in spec.split(":"))
        t0 = time.perf_counter()
        grid = build_grid(env, args.lss, size / n, n_a)
        grid.continuations(8)  # cached on the grid: the kernel below only iterates
        t_setup = time.perf_counter() - t0
        k = surveillance_kernel(env, args.lss, args.ratio, 1.0, grid=grid)
        t_iter = max(k.seconds, 1e-9)
        rate = k.states * k.iterations / t_iter
        print(f"{n:>5} {n_a:>5} {k.states:>10} {k.free_states:>10} {t_setup:>8.2f} "
              f"{t_iter:>8.2f} {k.iterations:>6} {rate:>14.3g} {t_setup + k.seconds:>8.2f} "
              f"{100 * k.safe_fraction_total():>7.2f}")


if __name__ == "__main__":
    main()
