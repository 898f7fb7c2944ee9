"""Speed of the certified kernel (issue #22): where the time goes, against the conservative grid
kernel on the same lattice.

For each mesh spacing (``h`` = map size / N) the table gives the grid kernel (``inner``, 180
orientations: the certified search starts from it), the first field, the LP rounds (count and
time) and the exact checks, the mesh's size, whether the field is certified and the total. The
search's time is split into the free windows (blocked spans and their windows), the LP
(HiGHS), the end rows (their bounds and the cutting planes) and the checks (``certify``); the
total is also given in CPU seconds of this process (the machine is shared: wall times are
noisy, say so and give the load average when quoting them). The issue's goal: within 3x the
``inner`` scheme's time on the gallery at N = 100.

Usage::

    python benchmarks/bench_certified.py [--map gallery] [--ratio 0.3] [--sizes 40,60,100]
"""

from __future__ import annotations

import argparse
import time

from tether.examples import path as example_path
from tether.game import surveillance_kernel
from tether.game.certificate import first_field
from tether.game.field_lp import solve_field
from tether.io import load_map


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--map", default="gallery", help="a bundled example's name")
    ap.add_argument("--ratio", type=float, default=0.3, help="vt/vo (vo = 1)")
    ap.add_argument("--lss", type=float, default=1.0)
    ap.add_argument("--sizes", default="40,60,100", help="comma-separated N (h = size/N)")
    args = ap.parse_args()
    env = load_map(example_path(args.map))
    x0, y0, x1, y1 = env.bounds
    size = max(x1 - x0, y1 - y0)
    frame, space = env.frame, env.internal  # the frame certified_kernel works in
    lss, vt, vo = args.lss * frame.scale, args.ratio, 1.0
    print(f"{args.map}, lss {args.lss:g}, vt/vo {args.ratio:g}")
    print(f"{'N':>5} {'vertices':>9} {'inner s':>8} {'first s':>8} {'LP rounds':>10} "
          f"{'search s':>9} {'windows':>8} {'LP':>8} {'ends':>8} {'checks':>8} "
          f"{'certified':>10} {'total s':>8} {'x inner':>8} {'cpu s':>8}")
    for n in (int(x) for x in args.sizes.split(",")):
        h = size / n * frame.scale
        c0 = time.process_time()
        t0 = time.perf_counter()
        kern = surveillance_kernel(space, lss, vt, vo, h=h, orientations=180)
        t1 = time.perf_counter()
        f0 = first_field(kern)
        t2 = time.perf_counter()
        f, checks, log = solve_field(space, kern, lss, vt, vo)
        t3 = time.perf_counter()
        cpu = time.process_time() - c0
        rounds = sum(e.get("rounds", 0) for e in log)
        split = [sum(e.get(key, 0.0) for e in log)
                 for key in ("t_windows", "t_lp", "t_ends", "t_certify")]
        ok = checks is not None and checks.passed
        total = t3 - t0
        # solve_field makes its own first field: the search time is net of it
        print(f"{n:>5} {len(f0.points):>9} {t1 - t0:>8.2f} {t2 - t1:>8.2f} {rounds:>10} "
              f"{t3 - t2 - (t2 - t1):>9.2f} "
              + " ".join(f"{x:>8.2f}" for x in split)
              + f" {str(ok):>10} {total:>8.2f} {total / (t1 - t0):>8.1f} {cpu:>8.2f}",
              flush=True)


if __name__ == "__main__":
    main()
