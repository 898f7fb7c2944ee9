"""The memory estimate against the measured peak → ``docs/memory.md``.

Run ``python docs/memory_table.py [--sizes 200 400 600 800 1000] [--divs 25 15 10]``: for
each seeded floor plan (``floor_plan(n, seed=0)``) and rod length ``lss = width / div`` it runs
``tether analyze`` (decompose, self-check, G, elimination and the critical-length check, as
the command does) in a fresh process, records its peak resident memory (``ru_maxrss``) and
prints it beside the estimate of :func:`tether.curves.budget.estimate_memory` (made before any
curve) and beside the exact vertex estimate's bound (made after the critical intervals,
:data:`tether.curves.budget.BYTES_PER_EXACT_VERTEX`). The runs are kept in
``docs/memory_runs.json``; ``--reuse`` rewrites the page from them. The default sizes take
about half an hour on the shared 2-core machine (most of it at 800 and 1,000 vertices, lss =
width / 10).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
RUNS = HERE / "memory_runs.json"
PAGE = HERE / "memory.md"

CHILD = r"""
import json, resource, sys, time
import tether.curves as C
from tether.analysis import analyze
from tether.decomposition import decompose
from tether.examples.floorplan import floor_plan

n, div = int(sys.argv[1]), float(sys.argv[2])
env = floor_plan(n, seed=0)
lss = (env.bounds[2] - env.bounds[0]) / div
seen = {}
check = C.check_vertex_budget
def spy(vertices, lss_internal):
    seen["exact"] = vertices
C.check_vertex_budget = spy  # record the exact estimate; refuse nothing
import tether._util.memory as M
M.memory_budget = lambda: M.MemoryBudget(None, "none")
t = time.perf_counter()
dec = decompose(env, lss)
dec_peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
verdict = analyze(dec)
print(json.dumps({"n": env.n, "div": div, "lss": lss, "exact": seen["exact"],
                  "decompose_kb": dec_peak,
                  "peak_kb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
                  "seconds": time.perf_counter() - t, "regions": len(dec.regions),
                  "cells": len(dec.cells), "pieces": len(dec.pieces),
                  "critical": verdict.critical is not None}))
"""


def measure(n: int, div: float) -> dict:
    """One run in a fresh process."""
    out = subprocess.run([sys.executable, "-c", CHILD, str(n), str(div)], check=True,
                         capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def estimate(run: dict) -> dict:
    """The estimate of the run's map and lss (made again: milliseconds)."""
    from tether.curves.budget import (
        BASE_BYTES,
        BYTES_PER_EXACT_CELL,
        BYTES_PER_EXACT_VERTEX,
        estimate_memory,
    )
    from tether.examples.floorplan import floor_plan

    env = floor_plan(run["n"], seed=0)
    est = estimate_memory(env, run["lss"])
    return {"pairs": est.pairs, "cells": est.cells, "estimate": est.bytes,
            "exact_bound": BASE_BYTES + BYTES_PER_EXACT_VERTEX * run["exact"]
            + BYTES_PER_EXACT_CELL * est.cells}


def refusal_example() -> dict:
    """``tether analyze`` on a 4,000-vertex floor plan with a 4 GB budget: the command, its
    one line and its wall time (a fresh process)."""
    import tempfile
    import time

    from tether.examples.floorplan import floor_plan
    from tether.io import save_map

    env = floor_plan(4000, seed=0)
    lss = round((env.bounds[2] - env.bounds[0]) / 15, 2)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "plan-4000.json"
        save_map(env, path)
        argv = ["analyze", str(path), "--lss", f"{lss:g}", "--memory-limit", "4G"]
        t = time.perf_counter()
        out = subprocess.run([sys.executable, "-m", "tether.cli", *argv],
                             capture_output=True, text=True)
        seconds = time.perf_counter() - t
    argv[1] = "plan-4000.json"
    return {"command": "tether " + " ".join(argv), "error": out.stderr.strip(),
            "status": out.returncode, "seconds": seconds}


def big_estimates() -> dict[int, float]:
    """The estimates (bytes) at 2,000 and 4,000 vertices, lss = width / 15."""
    from tether.curves.budget import estimate_memory
    from tether.examples.floorplan import floor_plan

    out = {}
    for n in (2000, 4000):
        env = floor_plan(n, seed=0)
        out[n] = estimate_memory(env, (env.bounds[2] - env.bounds[0]) / 15).bytes
    return out


def page(runs: list[dict], example: dict, big: dict[int, float]) -> str:
    """The markdown page."""
    mb = 1 << 20
    rows = []
    ratios = []
    for r in runs:
        e = estimate(r)
        peak = r["peak_kb"] * 1024
        ratios.append(e["estimate"] / peak)
        rows.append(f"| {r['n']} | {r['lss']:.3g} (w/{r['div']:g}) | {e['pairs']:,} | "
                    f"{e['cells']:,.0f} | {r['cells']:,} | {e['estimate'] / mb:,.0f} | "
                    f"{e['exact_bound'] / mb:,.0f} | {r['decompose_kb'] / 1024:,.0f} | "
                    f"{peak / mb:,.0f} | "
                    f"{'yes' if r['critical'] else 'no'} | {e['estimate'] / peak:.2f} |")
    lo, hi = min(ratios), max(ratios)
    return "\n".join([
        "# Memory: the budget and the estimate",
        "",
        "Generated by `python docs/memory_table.py` (the runs are in "
        "`docs/memory_runs.json`); do not edit by hand.",
        "",
        "tether refuses a decomposition that would not fit in memory **before** computing it, "
        "in one line (exit status 2), within milliseconds of loading the map:",
        "",
        "```console",
        f"$ {example['command']}",
        example["error"],
        "```",
        "",
        f"(the command took {example['seconds']:.1f} s in all, most of it loading the "
        "4,000-vertex map; the estimate and the search for what fits took milliseconds.)",
        "",
        "**The budget** is the memory this process may use: `--memory-limit SIZE` (`8G`, "
        "`500M`; K, M, G, T are powers of 1024) or the environment variable "
        "`TETHER_MEMORY_LIMIT` if given, else the smallest of the available physical memory "
        "(`MemAvailable` of `/proc/meminfo`, plus what the process holds already), the "
        "cgroup's limit (`/sys/fs/cgroup/memory.max`, or cgroup v1's "
        "`memory.limit_in_bytes`) and the address-space limit `RLIMIT_AS` "
        "(`tether._util.memory.memory_budget`). `--memory-limit` is an option of every "
        "command that decomposes a map (`decompose`, `analyze`, `check`, `assess`, "
        "`simulate`, `sweep`); with `--workers N` each process has the budget.",
        "",
        "**The estimate** (`tether.curves.budget.estimate_memory`) is made from what costs "
        "milliseconds: the map's vertices `n`, the pairs (vertex, edge) closer than `lss` "
        "(`P`) and the polyline step of the curved critical curves, "
        "`step = sqrt(8 tol / lss)` radians (`tol` the curve tolerance). The cells are "
        "about `P² / n` (the regions grow with `P`, the free arcs over each with `P / n`):",
        "",
        "    peak ≈ 64 MB + 8850 n / step + 1660 P² / n  bytes",
        "",
        "fitted on the floor plans below against the peak of `tether analyze` (which, near a "
        "critical length, decomposes the map twice more), then raised by 10 %. The refusal "
        "names the largest `lss` and the smallest curve tolerance that fit by the same "
        "estimate. After the critical intervals, the exact count of polyline "
        "vertices is checked again against the budget (940 bytes a vertex and 1445 a cell, "
        "the column *exact bound*), and against `tether.curves.MAX_CURVE_VERTICES` if a "
        "program sets it (it is None by default: the memory budget replaced its fixed 1.5 "
        "million vertices).",
        "",
        "**How good it is.** Peaks in MB; *decompose* is the peak after `decompose` alone, "
        "*critical* whether `analyze` checked a nearby critical length (two more "
        "decompositions), *ratio* the estimate over the measured peak:",
        "",
        "| vertices | lss | pairs P | cells P²/n | cells | estimate | exact bound | "
        "decompose | peak (analyze) | critical | ratio |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
        *rows,
        "",
        f"The estimate is {lo:.2f} to {hi:.2f} times the measured peak on these runs (the "
        "most at 200 vertices, where the base dominates). It does not see the threads "
        "(`TETHER_THREADS`): on a 16-core machine the issue measured 1.5 times the "
        "one-thread peak at 1,000 vertices. Beyond 1,000 vertices it is an extrapolation: at "
        f"2,000 vertices (lss = width / 15) it says {big[2000] / (1 << 30):.1f} GB where the "
        "issue measured 3.7 GB for decompose + analyze without the self-check and the "
        f"critical-length check; at 4,000 it says {big[4000] / (1 << 30):.0f} GB, refused on "
        "this 24 GB machine at once (a decomposition in tiles, not built yet, is the way "
        "there). On these plans `analyze` finds "
        "a critical length near almost every lss tried (the column *critical*), so the "
        "measured peaks include its two extra decompositions: away from critical lengths the "
        "peak is closer to the *decompose* column plus G.",
        "",
    ])


def main() -> int:
    """Measure (or reuse) the runs and write the page."""
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--sizes", type=int, nargs="+", default=[200, 400, 600, 800, 1000])
    p.add_argument("--divs", type=float, nargs="+", default=[25, 15, 10])
    p.add_argument("--reuse", action="store_true",
                   help="rewrite the page from the saved runs (memory_runs.json)")
    args = p.parse_args()
    if args.reuse:
        runs = json.loads(RUNS.read_text())
    else:
        runs = []
        for n in args.sizes:
            for div in args.divs:
                run = measure(n, div)
                print(f"{n} vertices, lss w/{div:g}: peak {run['peak_kb'] // 1024} MB "
                      f"({run['seconds']:.0f} s)", file=sys.stderr, flush=True)
                runs.append(run)
                RUNS.write_text(json.dumps(runs, indent=1) + "\n")  # kept as they come
    PAGE.write_text(page(runs, refusal_example(), big_estimates()))
    print(PAGE.read_text())
    return 0


if __name__ == "__main__":
    sys.exit(main())
