"""Benchmark: reading ROS occupancy maps into polygons, per stage, up to 1000 x 1000 cells.

Three kinds of generated maps at 5 cm per cell:

- ``offices``: a grid of 4 m rooms with 3-cell walls, 0.9 m doors and pillars (clean);
- ``slam``: the same with sensor noise: occupied speckles, unknown blobs, ragged wall edges;
- ``warehouse``: an open hall with rows of rack obstacles (many holes).

Stages: ``read`` (PGM decode + classify), ``component`` (4-connected component + diagonal pinch
closing), ``vectorize`` (boundary cell edges -> maximal segments -> ``shapely.line_merge``),
``simplify`` (hole dropping, topology-preserving simplification, Environment validation); the
column ``union`` times the other vectorizer (row runs -> rectangles -> ``shapely.union_all``),
the first implementation, for comparison. Times are wall
seconds, best of ``--repeat``; the machine is shared, so figures are noisy.

Run ``python benchmarks/bench_occupancy.py [--sizes 250 500 1000] [--repeat 2]``.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
from PIL import Image

from tether.io.ros import (
    _drop_small_holes,
    _to_environment,
    free_component,
    read_grid,
    vectorize,
)

F, O, U = 254, 0, 205


def offices(n: int, rng: np.random.Generator, noisy: bool = False) -> np.ndarray:
    img = np.full((n, n), O, dtype=np.uint8)
    img[3:-3, 3:-3] = F
    room = 80  # cells (4 m)
    for k in range(room, n - 3, room):
        img[k:k + 3, 3:-3] = O
        img[3:-3, k:k + 3] = O
    for k in range(room, n - 3, room):  # doors: 18 cells (0.9 m) in every wall segment
        for j in range(room // 2, n - 3, room):
            img[k:k + 3, j - 9:j + 9] = F
            img[j - 9:j + 9, k:k + 3] = F
    for i in range(room // 2, n - room // 2, room):  # a pillar in every other room
        for j in range(room // 2, n - room // 2, 2 * room):
            img[i - 4:i + 4, j - 4:j + 4] = O
    if noisy:
        speck = rng.random((n, n)) < 0.002
        img[speck & (img == F)] = O
        for _ in range(n // 20):
            i, j = rng.integers(10, n - 10, 2)
            r = rng.integers(2, 8)
            img[i - r:i + r, j - r:j + r] = U
        edge = (img == O) & (rng.random((n, n)) < 0.3)
        img[np.roll(edge, 1, axis=0) & (img == F)] = O
    return img


def warehouse(n: int, rng: np.random.Generator) -> np.ndarray:
    img = np.full((n, n), O, dtype=np.uint8)
    img[3:-3, 3:-3] = F
    for i in range(40, n - 40, 36):
        for j in range(40, n - 60, 70):
            img[i:i + 12, j:j + 50] = O
    return img


def bench(img: np.ndarray, folder: Path, repeat: int) -> dict:
    name = f"m{img.shape[0]}"
    Image.fromarray(img, mode="L").save(folder / f"{name}.pgm")
    yp = folder / f"{name}.yaml"
    yp.write_text(f"image: {name}.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
                  "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    best: dict = {}
    for _ in range(repeat):
        t = {}
        t0 = time.perf_counter()
        grid = read_grid(yp)
        t["read"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        mask = free_component(grid)
        t["component"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        poly = vectorize(mask)
        t["vectorize"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        env, _ = _to_environment(grid, _drop_small_holes(poly, 4.0), 1.0)
        t["simplify"] = time.perf_counter() - t0
        t["total"] = sum(t.values())
        t0 = time.perf_counter()
        vectorize(mask, method="union")
        t["union"] = time.perf_counter() - t0
        for k, v in t.items():
            best[k] = min(best.get(k, np.inf), v)
    best["cells"] = img.size
    best["raw_vertices"] = len(poly.exterior.coords) - 1 + sum(len(r.coords) - 1
                                                               for r in poly.interiors)
    best["vertices"] = env.n
    best["holes"] = len(env.holes)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[250, 500, 1000])
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args()
    rng = np.random.default_rng(1)
    kinds = {"offices": lambda n: offices(n, rng), "slam": lambda n: offices(n, rng, True),
             "warehouse": lambda n: warehouse(n, rng)}
    print(f"{'map':<10} {'cells':>9} {'read':>7} {'compon.':>7} {'vector.':>7} {'simplify':>8} "
          f"{'total s':>7} {'union':>7} {'raw vtx':>8} {'vertices':>8} {'holes':>6}")
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.sizes:
            for kind, make in kinds.items():
                r = bench(make(n), Path(tmp), args.repeat)
                print(f"{kind:<10} {n:>4}x{n:<4} {r['read']:7.3f} {r['component']:7.3f} "
                      f"{r['vectorize']:7.3f} {r['simplify']:8.3f} {r['total']:7.3f} "
                      f"{r['union']:7.3f} {r['raw_vertices']:8d} {r['vertices']:8d} "
                      f"{r['holes']:6d}")


if __name__ == "__main__":
    main()
