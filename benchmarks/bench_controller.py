"""Controller step time and simulation speed on the gallery map.

Run: ``python benchmarks/bench_controller.py``. The states come from a seeded run of the
random target; every controller steps from the same states. Timings are wall-clock on a shared
machine: noisy, compare medians.
"""

from __future__ import annotations

import time

import numpy as np

from tether.analysis import analyze
from tether.decomposition import decompose
from tether.examples import path as example_path
from tether.io import load_map
from tether.sim.protocols import World
from tether.sim.simulate import simulate
from tether.strategies import CONTROLLERS, make_target


def main() -> None:
    env = load_map(example_path("gallery"))
    dec = decompose(env, 2.0)
    w = World(env, 2.0, 0.5, 1.0, dec, analyze(dec))
    # the paper controller's own run (its decisions depend on its own past), replayed below
    run = simulate(w, CONTROLLERS["paper"](w), make_target("random", w), (2.0, 2.5, 0.5),
                   duration=60.0, dt=0.02, seed=0)
    tr = run.trace
    n = len(tr.mode)
    vs = np.diff(tr.p, axis=0) / run.dt
    print(f"gallery, lss=2, vt=0.5, vo=1, dt=0.02: {n} states from a random-target run")
    print(f"{'controller':<12} {'median µs':>10} {'p90 µs':>10} {'mean µs':>10}")
    for name in ("paper", "follow", "translate"):
        ctrl = CONTROLLERS[name](w)
        ctrl.reset(w, tr.p[0], float(tr.a[0]))
        times = np.empty(n)
        for i in range(n):
            p, v, a = tr.p[i], vs[i], float(tr.a[i])
            t0 = time.perf_counter()
            ctrl.step(p, v, a, run.dt)
            times[i] = time.perf_counter() - t0
        print(f"{name:<12} {1e6 * np.median(times):10.1f} {1e6 * np.percentile(times, 90):10.1f}"
              f" {1e6 * times.mean():10.1f}")
    print()
    print(f"{'simulation':<28} {'sim s / wall s':>15}")
    for label, kind, mon in (("paper vs random, monitor", "random", True),
                             ("paper vs random, no monitor", "random", False),
                             ("paper vs search, monitor", "search", True)):
        t0 = time.perf_counter()
        r = simulate(w, CONTROLLERS["paper"](w), make_target(kind, w), (2.0, 2.5, 0.5),
                     duration=20.0, dt=0.02, seed=1, monitor=mon)
        wall = time.perf_counter() - t0
        simulated = r.lost_at if r.lost_at is not None else r.duration
        print(f"{label:<28} {simulated / wall:15.1f}")


if __name__ == "__main__":
    main()
