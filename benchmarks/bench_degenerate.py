"""Benchmark: what the handling of maps not in general position costs (issue 21), on floor plans.

Run: ``python benchmarks/bench_degenerate.py [--sizes 400 1000] [--repeat 3]``.

Each size runs in a fresh process: one decomposition (CPU seconds, the reference), and, timed
on their own within it, the steps this handling adds (CPU seconds):

* ``merge``: collinear copies made one before noding
  (:func:`tether.decomposition.coincidence.merge_collinear`);
* ``stubs``: curve ends joined to walls they stop just short of (``_with_wall_stubs``);
* ``offline``: faces' points moved off lines through walls (``_off_edge_lines``);
* ``crit``: the search for critical lengths near ``lss``
  (:func:`tether.analysis.critical.near_critical`) that ``analyze`` runs;
* ``scan``: the 6 scanned lines of the self-check (``self_check`` minus ``self_check`` with
  ``lines=0``).

``share`` is their sum over the decomposition's CPU time (the issue's budget: 15 %). The
table is the run of least decomposition time per size (the machine is shared; its speed is on
the first line, as in ``bench_decompose.py``).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

CHILD = r"""
import json, sys, time
import tether.decomposition as D
from tether.analysis.critical import near_critical
from tether.decomposition import arrangement, pipeline
from tether.examples.floorplan import floor_plan

n = int(sys.argv[1])
env = floor_plan(n, seed=0)
lss = (env.bounds[2] - env.bounds[0]) / 15
spent = {"merge": 0.0, "stubs": 0.0, "offline": 0.0}

def timed(name, f):
    def g(*a, **k):
        t = time.process_time()
        out = f(*a, **k)
        spent[name] += time.process_time() - t
        return out
    return g

arrangement.merge_collinear = timed("merge", arrangement.merge_collinear)
arrangement._with_wall_stubs = timed("stubs", arrangement._with_wall_stubs)
pipeline._off_edge_lines = timed("offline", pipeline._off_edge_lines)
t = time.process_time()
dec = D.decompose(env, lss)
spent["decompose"] = time.process_time() - t
t = time.process_time()
near_critical(env, lss)
spent["crit"] = time.process_time() - t
dec.regions[0].structure  # the shared structures made, as the self-check needs them
t = time.process_time()
D.self_check(dec, lines=0)
t1 = time.process_time()
D.self_check(dec)
t2 = time.process_time()
spent["scan"] = (t2 - t1) - (t1 - t)
spent["points_pieces"] = t1 - t
print(json.dumps({"vertices": env.n, "regions": len(dec.regions), **spent}))
"""

COLUMNS = [("vertices", "verts", 6, "d"), ("regions", "regions", 8, "d"),
           ("decompose", "decomp", 8, ".2f"), ("merge", "merge", 7, ".3f"),
           ("stubs", "stubs", 7, ".3f"), ("offline", "offline", 8, ".3f"),
           ("crit", "crit", 7, ".3f"), ("points_pieces", "pts+pcs", 8, ".3f"),
           ("scan", "scan", 7, ".3f"), ("share", "share", 7, ".1%")]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[400, 1000])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
    from bench_decompose import machine_speed

    loop, sort = machine_speed()
    print(f"machine: python loop {loop:.3f} s, numpy sort {sort:.3f} s", flush=True)
    print("".join(f"{h:>{w}}" for _, h, w, _ in COLUMNS), flush=True)
    for n in args.sizes:
        runs = []
        for _ in range(args.repeat):
            out = subprocess.run([sys.executable, "-c", CHILD, str(n)], capture_output=True,
                                 text=True, check=True)
            runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
        r = min(runs, key=lambda x: x["decompose"])
        r["share"] = sum(r[k] for k in ("merge", "stubs", "offline", "crit", "scan")) \
            / r["decompose"]
        print("".join(f"{r[k]:>{w}{f}}" for k, _, w, f in COLUMNS), flush=True)


if __name__ == "__main__":
    main()
