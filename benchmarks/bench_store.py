"""Benchmark: a decomposition written to a store and read back (``docs/store.md``).

Run: ``python benchmarks/bench_store.py [--sizes 200 400 1000]``. For each seeded floor plan
(``floor_plan(n, seed=0)``, lss = width / 15) it decomposes, writes the store, reads it back,
and builds G and the elimination on both (the same verdict is asserted); it prints the wall
times (seconds), the store's size (MB) and the counts. Each size runs in a fresh process.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

CHILD = r"""
import json, sys, tempfile, time
from pathlib import Path
from tether.analysis import analyze
from tether.decomposition import decompose
from tether.decomposition.store import read_decomposition, write_decomposition
from tether.examples.floorplan import floor_plan

n = int(sys.argv[1])
env = floor_plan(n, seed=0)
lss = (env.bounds[2] - env.bounds[0]) / 15
out = {"n": env.n}
t = time.perf_counter(); dec = decompose(env, lss); out["decompose"] = time.perf_counter() - t
quick = {"self_check": False, "near_critical": False}
with tempfile.TemporaryDirectory() as tmp:
    t = time.perf_counter(); write_decomposition(dec, Path(tmp) / "s")
    out["write"] = time.perf_counter() - t
    out["mb"] = sum(p.stat().st_size for p in (Path(tmp) / "s").rglob("*")) / 2**20
    t = time.perf_counter(); back = read_decomposition(Path(tmp) / "s")
    out["read"] = time.perf_counter() - t
t = time.perf_counter(); v1 = analyze(dec, **quick); out["analyze_memory"] = time.perf_counter() - t
t = time.perf_counter(); v2 = analyze(back, **quick); out["analyze_store"] = time.perf_counter() - t
assert v1.to_dict() == v2.to_dict()
out.update(regions=len(dec.regions), cells=len(dec.cells), pieces=len(dec.pieces))
print(json.dumps(out))
"""


def main() -> int:
    """Print the table."""
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--sizes", type=int, nargs="+", default=[200, 400, 1000])
    p.add_argument("--src", help="run another checkout's src directory")
    args = p.parse_args()
    env = None
    if args.src:
        import os

        env = dict(os.environ, PYTHONPATH=str(Path(args.src).resolve()))
    print(" verts  decompose  write   read  G+elim(mem)  G+elim(store)  store MB   regions"
          "     cells    pieces")
    for n in args.sizes:
        res = subprocess.run([sys.executable, "-c", CHILD, str(n)], capture_output=True,
                             text=True, check=True, env=env)
        r = json.loads(res.stdout.strip().splitlines()[-1])
        print(f"{r['n']:>6} {r['decompose']:>10.2f} {r['write']:>6.2f} {r['read']:>6.2f} "
              f"{r['analyze_memory']:>12.2f} {r['analyze_store']:>14.2f} {r['mb']:>9.1f} "
              f"{r['regions']:>9} {r['cells']:>9} {r['pieces']:>9}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
