"""Benchmark: decompose + analyze on seeded floor plans, time per stage and peak memory.

Run: ``python benchmarks/bench_decompose.py [--sizes 100 200 400 800 1000] [--src DIR]``.
Each size runs in a fresh process (peak resident memory is that process's ``ru_maxrss``);
``--src`` points the child processes at another checkout's ``src`` (e.g. the code before a
change) to print a before/after table. Goals (issue 8): 400 vertices under 3 s, 1,000
vertices under 10 s and under 1 GB, decompose + analyze. The machine is shared: times are
noisy and its speed drifts over minutes: ``--repeat 3`` keeps each size's run of least CPU
time, ``--base OLD/src`` runs the old code interleaved with the new and prints the ratio.

The first line measures the machine (:func:`machine_speed`: a fixed pure-Python loop and a
fixed numpy sort, best of 5): this VM's speed drifts by up to 2x between days (the same code
took 16.1 s at 1,000 vertices on 2026-11-25 and 8.7 s on 2026-11-26), so compare figures of
different days through it.

Columns: vertices, pairs (vertex, edge) within lss, lss, stage CPU times in seconds (critical
curves, arrangement, face structures, regions, pieces, the conversion back to the map's frame
and names, graph G, elimination, self-check), total wall time and its CPU time (the machine
is shared: CPU time is the steadier figure), peak resident memory in MB, and counts (curves,
regions, cells, pieces).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

CHILD = r"""
import json, resource, sys, time
import numpy as np
try:
    from tether.examples.floorplan import floor_plan
except ImportError:  # a tree before tether.examples (issue 23)
    from tether.floorplan import floor_plan
from tether.decomposition import decompose

n = int(sys.argv[1])
env = floor_plan(n, seed=0)
lss = (env.bounds[2] - env.bounds[0]) / 15

def pairs_within_reach(env, lss):
    pidx, eidx = env.edge_index(lss).query(env.vertices)
    A, B, _, _ = env.oriented_edges
    p = env.vertices[pidx]
    a, b = A[eidx], B[eidx]
    d = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, d) / np.einsum("ij,ij->i", d, d), 0, 1)
    return int(np.sum(np.hypot(*(a + t[:, None] * d - p).T) < lss))

stages = {}
mark = [time.process_time(), None]
def progress(stage, frac):
    now = time.process_time()
    if mark[1] is not None:
        stages[mark[1]] = stages.get(mark[1], 0.0) + now - mark[0]
    mark[0], mark[1] = now, stage

c0 = time.process_time()
w0 = time.perf_counter()
dec = decompose(env, lss, progress=progress)
t1 = time.process_time()
try:
    from tether.analysis import analyze, build_graph
except ImportError:  # a tree before tether.analysis (issue 23)
    from tether.escape import analyze
    from tether.graph import build_graph
g = build_graph(dec)
t2 = time.process_time()
try:
    v = analyze(dec, g, self_check=False, near_critical=False)
except TypeError:  # before the critical lengths (or the self-check) existed
    try:
        v = analyze(dec, g, self_check=False)
    except TypeError:
        v = analyze(dec, g)
t3 = time.process_time()
try:  # the search for critical lengths near lss that analyze runs by default
    try:
        from tether.analysis.critical import near_critical
    except ImportError:  # a tree before tether.analysis (issue 23)
        from tether.critical import near_critical
    critical = bool(near_critical(env, lss)[0])
except ImportError:
    critical = None
t3b = time.process_time()
try:
    from tether.decomposition import self_check
    ok = self_check(dec).ok
except ImportError:
    ok = None
t4 = time.process_time()
peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps({
    "vertices": env.n, "pairs": pairs_within_reach(env, lss), "lss": lss,
    "curves_s": stages.get("critical curves", 0), "arrangement_s": stages.get("arrangement", 0),
    "faces_s": stages.get("face structures", 0), "regions_s": stages.get("regions", 0),
    "pieces_s": stages.get("pieces", 0), "graph_s": t2 - t1, "elim_s": t3 - t2,
    "frame_s": t1 - mark[0], "critical_s": t3b - t3, "selfcheck_s": t4 - t3b,
    "total_s": time.perf_counter() - w0,
    "cpu_s": t4 - c0,
    "peak_mb": peak_mb,
    "curves": len(dec.curves), "regions": len(dec.regions), "cells": len(dec.cells),
    "pieces": len(dec.pieces), "strategy": v.strategy_exists, "self_check": ok,
    "near_critical": critical}))
"""

COLUMNS = [("vertices", "verts", 6, "d"), ("pairs", "pairs", 7, "d"), ("lss", "lss", 5, ".2f"),
           ("curves_s", "curves", 7, ".2f"), ("arrangement_s", "arrang", 7, ".2f"),
           ("faces_s", "faces", 6, ".2f"), ("regions_s", "regions", 8, ".2f"),
           ("pieces_s", "pieces", 7, ".2f"), ("frame_s", "frame", 6, ".2f"),
           ("graph_s", "G", 6, ".2f"),
           ("elim_s", "elim", 6, ".2f"), ("critical_s", "crit", 6, ".2f"),
           ("selfcheck_s", "selfck", 7, ".2f"),
           ("total_s", "TOTAL s", 8, ".2f"), ("cpu_s", "CPU s", 7, ".2f"),
           ("peak_mb", "peak MB", 8, ".0f"),
           ("curves", "#curv", 7, "d"), ("regions", "#reg", 7, "d"), ("cells", "#cells", 7, "d"),
           ("pieces", "#pcs", 7, "d")]


def machine_speed() -> tuple[float, float]:
    """Seconds for a fixed pure-Python loop and a fixed numpy sort (best of 5 each): the
    machine's speed at the time of the run, to compare benchmark tables of different days."""
    import time

    import numpy as np

    def best(f) -> float:
        times = []
        for _ in range(5):
            t = time.perf_counter()
            f()
            times.append(time.perf_counter() - t)
        return min(times)

    data = np.random.default_rng(0).random(2_000_000)
    return (best(lambda: sum(i * i for i in range(1_000_000))), best(lambda: np.sort(data)))


def run_size(n: int, src: str | None, timeout: float) -> dict | None:
    """One size in a fresh interpreter; None if it failed or timed out."""
    env = dict(os.environ)
    if src:
        env["PYTHONPATH"] = str(Path(src).resolve())
    try:
        out = subprocess.run([sys.executable, "-c", CHILD, str(n)], capture_output=True,
                             text=True, env=env, timeout=timeout)
    except subprocess.TimeoutExpired:
        print(f"{n:>6}  timed out after {timeout:g} s", flush=True)
        return None
    if out.returncode != 0:
        last = (out.stderr.strip().splitlines() or ["?"])[-1]
        print(f"{n:>6}  failed: {last}", flush=True)
        return None
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[100, 200, 400, 800, 1000])
    ap.add_argument("--src", help="run another checkout's src directory (before/after)")
    ap.add_argument("--base", help="also run this checkout's src directory, interleaved with "
                    "the code under test (the machine's speed drifts: compare neighbours), "
                    "and print the CPU ratio")
    ap.add_argument("--repeat", type=int, default=1,
                    help="runs per size (and code), the one of least CPU time printed")
    ap.add_argument("--timeout", type=float, default=600.0, help="seconds per size")
    args = ap.parse_args()
    loop, sort = machine_speed()
    print(f"machine: python loop {loop:.3f} s, numpy sort {sort:.3f} s (threads: "
          f"{os.environ.get('TETHER_THREADS', 'all cores')}, {os.cpu_count()} cpus)", flush=True)
    label = "code  " if args.base else ""
    print(label + "".join(f"{h:>{w}}" for _, h, w, _ in COLUMNS), flush=True)
    for n in args.sizes:
        codes = ((args.base, "base  "), (args.src, "now   ")) if args.base else ((args.src, ""),)
        runs: list[list[dict | None]] = [[] for _ in codes]
        for _ in range(args.repeat):  # interleaved: base, new, base, new, ...
            for k, (src, _) in enumerate(codes):
                runs[k].append(run_size(n, src, args.timeout))
        rows = []
        for got, (_, name) in zip(runs, codes, strict=True):
            if all(r is not None for r in got):
                r = min(got, key=lambda r: r["cpu_s"])  # the least disturbed run
                rows.append(r)
                print(name + "".join(f"{r[k]:>{w}{f}}" for k, _, w, f in COLUMNS), flush=True)
        if args.base and len(rows) == 2:
            print(f"ratio  {rows[1]['cpu_s'] / rows[0]['cpu_s']:.2f} of the base's CPU time, "
                  f"peak {rows[1]['peak_mb']:.0f} / {rows[0]['peak_mb']:.0f} MB", flush=True)


if __name__ == "__main__":
    main()
