"""Invariance sweep: random maps under random similarities, ring reorderings and collinear
vertex insertions; counts, G's edges, verdict and check must not change.

Run: ``python tools/invariance_sweep.py [maps] [seed]`` (default 20 maps, seed 0). Prints
one row per map and transform and a summary line (issue 9). Maps are random star-shaped
boundaries with up to two convex holes, lss in [1, 5].
"""

from __future__ import annotations

import math
import sys
import time

import numpy as np

from tether import Environment, InvalidMapError
from tether.analysis import analyze, build_graph
from tether.decomposition import check, decompose


def random_map(rng: np.random.Generator) -> Environment:
    k = int(rng.integers(4, 11))
    t = np.cumsum(rng.uniform(0.2, 1.0, k))
    t = 2 * math.pi * t / t[-1]
    r = rng.uniform(3.0, 10.0, k)
    boundary = np.column_stack((r * np.cos(t), r * np.sin(t)))
    outer = Environment(boundary)
    holes: list[np.ndarray] = []
    from shapely.geometry import Polygon

    for _ in range(int(rng.integers(0, 3))):
        c = rng.uniform(-2, 2, 2)
        a = rng.uniform(0, 2 * math.pi) + np.linspace(0, 2 * math.pi, int(rng.integers(3, 7)),
                                                      endpoint=False)
        hole = c + rng.uniform(0.3, 1.2) * np.column_stack((np.cos(a), np.sin(a)))
        hp = Polygon(hole)
        if outer.polygon.buffer(-0.05).contains(hp) and all(
                hp.distance(Polygon(h)) > 0.05 for h in holes):
            holes.append(hole)
    return Environment(boundary, tuple(holes), "random")


def summary(env: Environment, lss: float) -> tuple:
    d = decompose(env, lss)
    g = build_graph(d)
    return (len(d.regions), len(d.cells), len(d.pieces), len(g.edge_list),
            analyze(d, g).strategy_exists, check(d, 4).ok)


def similar(env: Environment, rng: np.random.Generator) -> tuple[Environment, float, str]:
    k = 10.0 ** rng.uniform(-3, 4)
    a = rng.uniform(0, 2 * math.pi)
    mirror = bool(rng.integers(0, 2))
    off = rng.uniform(-1e6, 1e6, 2) * env.diameter * k
    m = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]]) * k
    if mirror:
        m = m @ np.diag([-1.0, 1.0])
    moved = Environment(env.boundary @ m.T + off, tuple(h @ m.T + off for h in env.holes))
    return moved, k, f"scale {k:.2g} rot {a:.2f} off {np.abs(off).max():.1e}" + \
        (" mirror" if mirror else "")


def reordered(env: Environment, rng: np.random.Generator) -> Environment:
    rings = []
    for r in env.rings:
        r = np.roll(r, -int(rng.integers(0, len(r))), axis=0)
        rings.append(r[::-1] if rng.integers(0, 2) else r)
    return Environment(rings[0], tuple(rings[1:]))


def collinear(env: Environment, rng: np.random.Generator) -> Environment:
    out = []
    ring = env.boundary
    for i in range(len(ring)):
        a, b = ring[i], ring[(i + 1) % len(ring)]
        out.append(a[None])
        k = int(rng.integers(0, 4))
        if k:
            out.append(a + (np.arange(1, k + 1)[:, None] / (k + 1)) * (b - a))
    return Environment(np.vstack(out), env.holes)


def main(n: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    same = diff = rejected = 0
    print(f"{'map':>4} {'lss':>6} {'transform':<46}{'base':>28}  result")
    t0 = time.perf_counter()
    for i in range(n):
        env = random_map(rng)
        lss = float(rng.uniform(1.0, 5.0))
        base = summary(env, lss)
        moved, k, text = similar(env, rng)
        cases = [(text, moved, lss * k), ("ring start/orientation", reordered(env, rng), lss),
                 ("collinear vertices", collinear(env, rng), lss)]
        for name, other, ls in cases:
            try:
                got = summary(other, ls)
            except InvalidMapError as exc:
                rejected += 1
                print(f"{i:>4} {lss:>6.2f} {name:<46}{'':>28}  rejected: {exc}")
                continue
            ok = got == base
            same += ok
            diff += not ok
            print(f"{i:>4} {lss:>6.2f} {name:<46}{str(base):>28}  "
                  f"{'same' if ok else 'DIFFERENT ' + str(got)}")
    print(f"{same} same, {diff} different, {rejected} rejected; "
          f"{time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 20,
         int(sys.argv[2]) if len(sys.argv) > 2 else 0)
