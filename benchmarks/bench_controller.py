"""Controller step time and simulation speed on the gallery map, and the certified
controller's runs on the 10 x 10 room with a corner (``nonconvex_corner``, vt/vo 0.3, mesh
0.25).

Run: ``python benchmarks/bench_controller.py`` (``--certified``: the certified part only). The
states come from a seeded run of the random target; every controller steps from the same
states. Timings are wall-clock on a shared machine: noisy, compare medians. The certified
runs are timed in CPU seconds of this process (less noisy under load): the search target
scoring its plans in one batch (``step_many``) and one plan at a time (the loop kept for
controllers without ``step_many``), against the same states.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from tether.analysis import analyze
from tether.decomposition import decompose
from tether.examples import path as example_path
from tether.io import load_map
from tether.sim.protocols import World
from tether.sim.simulate import simulate
from tether.strategies import CONTROLLERS, make_target


def certified() -> None:
    """The certified controller: one step (plain floats) against ``step_many`` per row, and
    whole runs (15 s, dt 0.02, monitor on) per target kind, CPU seconds."""
    from tether.game.certified import certified_kernel
    from tether.game.controller import CertifiedController
    from tether.strategies import TARGETS

    env = load_map(example_path("nonconvex_corner"))
    ck = certified_kernel(env, 1.0, 0.3, 1.0, h=0.25)
    w = World(env, 1.0, 0.3, 1.0, extra={"certified": ck})
    run = simulate(w, CertifiedController(), make_target("random", w), (5.0, 5.0, 0.0),
                   duration=15.0, dt=0.02, seed=0)
    tr = run.trace
    vs = np.diff(tr.p, axis=0) / run.dt
    ctrl = CertifiedController()
    ctrl.reset(w, tr.p[0], float(tr.a[0]))
    n = len(vs)
    t0 = time.process_time()
    for i in range(n):
        ctrl.step(tr.p[i], vs[i], float(tr.a[i]), run.dt)
    one = (time.process_time() - t0) / n
    t0 = time.process_time()
    for _ in range(5):
        ctrl.step_many(tr.p[:-1], vs, tr.a[:-1], run.dt)
    many = (time.process_time() - t0) / (5 * n)
    print(f"\nnonconvex_corner, lss=1, vt=0.3, vo=1, certified h=0.25: {n} states")
    print(f"certified step {1e6 * one:.1f} µs; step_many {1e6 * many:.1f} µs a row ({n} rows)")

    class Looped(CertifiedController):  # no step_many: the search target's loop
        step_many = property(lambda self: (_ for _ in ()).throw(AttributeError))

    print(f"{'target':<16} {'CPU s / run':>12} {'runs / CPU-hour':>16}")
    kinds = sorted(set(TARGETS) - {"path", "track", "pedestrian"})
    for label, kind, cls in [(k, k, CertifiedController) for k in kinds] + [
            ("search (loop)", "search", Looped)]:
        world = World(env, 1.0, 0.3, 1.0, extra={"certified": ck})
        if kind == "kernel-evader":  # its grid kernel, computed once (not timed)
            from tether.game.controller import kernel_of

            kernel_of(world)
        t0 = time.process_time()
        simulate(world, cls(), make_target(kind, world), (5.0, 5.0, 0.0), duration=15.0,
                 dt=0.02, seed=1)
        cpu = time.process_time() - t0
        print(f"{label:<16} {cpu:12.2f} {3600 / cpu:16.0f}")


def main() -> None:
    if "--certified" in sys.argv[1:]:
        certified()
        return
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
    certified()


if __name__ == "__main__":
    main()
