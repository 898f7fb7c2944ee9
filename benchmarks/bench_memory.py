"""Benchmark: what the main process holds per region, cell, piece and edge of G.

Run: ``python benchmarks/bench_memory.py [--sizes 1000 2000] [--workers 2] [--tiles auto]``.
Each size runs in a fresh process: ``floor_plan(n, seed=0)``, ``lss = width / 15`` (the rule
of ``bench_scale.py``), decomposed in tiles on ``--workers`` spawned processes, then G built
and the elimination run. It prints, per size, the counts, the bytes held by the finished
:class:`~tether.decomposition.Decomposition` and :class:`~tether.analysis.ConnectivityGraph`
component by component, each also per object (per region, cell, piece or edge):

- ``columns``: the numpy arrays (``nbytes``);
- ``python``: the Python objects (records, tuples, floats, strings, lists, dicts) measured by
  ``sys.getsizeof`` walked over the object graph (a shared object counted once);
- ``geos``: shapely geometries (the regions' polygons and the faces of the multi-face regions
  whose union is not made yet, the pieces' lines), measured as the resident-memory growth
  when an equal copy of them is made from WKB (``malloc_trim`` first), and their coordinate
  count (16 bytes each, the floor of any representation).

and the stage peaks of the main process (resident memory after ``decompose`` with the
workers shut down, the ``tracemalloc`` peak of G's build and of the elimination, the numpy
buffers included, and the process's peak resident memory). Timings are wall seconds with the
load average at the start.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

CHILD = r"""
import gc, json, os, sys, time, tracemalloc
import numpy as np, psutil, resource, shapely
from tether._util.memory import release_memory
from tether.analysis import build_graph
from tether.analysis.elimination import analyze, eliminate
from tether.decomposition import decompose
from tether.decomposition.tiles import process_executor
from tether.examples.floorplan import floor_plan

n, workers, tiles = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
proc = psutil.Process()

def rss():
    gc.collect()
    release_memory()
    return proc.memory_info().rss

def deep(obj, seen):
    # sys.getsizeof over the object graph of Python containers and records (numpy arrays
    # and shapely geometries are counted apart, as columns and geos)
    total, stack = 0, [obj]
    while stack:
        o = stack.pop()
        if id(o) in seen or isinstance(o, (np.ndarray, shapely.Geometry, type)) or o is None:
            continue
        seen.add(id(o))
        total += sys.getsizeof(o)
        if isinstance(o, dict):
            stack.extend(o.keys()); stack.extend(o.values())
        elif isinstance(o, (list, tuple, set, frozenset)):
            stack.extend(o)
        elif hasattr(o, "__dict__") and not isinstance(o, (str, bytes, int, float)):
            stack.append(vars(o))
        if hasattr(o, "__slots__") and not isinstance(o, (str, bytes, int, float, dict)):
            for cls in type(o).__mro__:
                for s in getattr(cls, "__slots__", ()):
                    if hasattr(o, s) and s != "__weakref__":
                        stack.append(getattr(o, s))
    return total

def columns(obj, attrs):
    return sum(getattr(obj, a).nbytes for a in attrs
               if isinstance(getattr(obj, a, None), np.ndarray))

def geos(geoms):
    geoms = np.asarray([g for g in geoms if g is not None], dtype=object)
    coords = int(shapely.get_num_coordinates(geoms).sum()) if len(geoms) else 0
    wkb = shapely.to_wkb(geoms)
    base = rss()
    copy = shapely.from_wkb(wkb)
    got = rss() - base
    del copy
    return got, coords, len(geoms)

env = floor_plan(n, seed=0)
lss = (env.bounds[2] - env.bounds[0]) / 15
out = {"vertices": n, "load": os.getloadavg()[0]}
r0 = rss()
t = time.perf_counter()
ex = process_executor(workers)
dec = decompose(env, lss, tiles=tiles, executor=ex)
ex.shutdown()
out["decompose_s"] = time.perf_counter() - t
r1 = rss()
out["rss_env_MB"] = r0 / 2**20
out["rss_decomposition_MB"] = (r1 - r0) / 2**20
out["peak_decompose_MB"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
nr, nc, npc = len(dec.regions), len(dec.cells), len(dec.pieces)
out.update(regions=nr, cells=nc, pieces=npc, curves=len(dec.curves))
parts = {}
seen = set()
# regions: the records, the shared structures and polygons
regs = dec.regions
lean = hasattr(regs, "_table")  # Regions: columns, records made when read
shapes = regs._table.shapes if lean else regs[0]._polygon
structs = regs._table.structures if lean else regs[0]._structure
py = deep(regs, seen)  # the records (a tuple of them), points, floats, ints; or the view
held, _ = shapes.held()
faces = [f for fs in shapes.pending_unions().values() for f in fs]
g_b, g_c, g_n = geos(list(held) + faces)
cols = columns(structs, ("ptr", "pairs", "region"))
if lean:
    cols += columns(regs._table, ("area", "point"))
parts["regions"] = {"per": nr, "columns": cols, "python": py + deep(structs._sets, seen),
                    "geos": g_b, "coords": g_c, "geoms": g_n}
table = dec.cells._table
parts["cells"] = {"per": nc, "columns": columns(table, ("region", "start", "end", "first")),
                  "python": deep(table.names, seen)}
pt = dec.pieces._table
pg, _ = pt.shapes.held()
g_b, g_c, g_n = geos(pg)
parts["pieces"] = {"per": npc, "columns": columns(pt, ("pair", "q", "n", "eps", "ok", "desc")),
                   "python": deep(pt.descs, seen), "geos": g_b, "coords": g_c, "geoms": g_n}
arcs = dec.crossing_arcs()
parts["crossing arcs"] = {"per": npc, "columns": columns(arcs, ("point", "start", "end",
                          "start_code", "end_code", "full"))}
cc = dec.cell_codes()
parts["cell codes"] = {"per": nc, "columns": sum(a.nbytes for a in cc
                       if not any(a is b for b in (table.region, table.start, table.end)))}
cv = sum(p.nbytes + q.nbytes for c in dec.curves for p, q in zip(c.polylines, c.params))
parts["curves"] = {"per": max(len(dec.curves), 1), "columns": cv,
                   "python": deep(dec.curves, seen)}
# G and the elimination
gc.collect()
tracemalloc.start()
t = time.perf_counter()
g = build_graph(dec)
out["graph_s"] = time.perf_counter() - t
_, peak = tracemalloc.get_traced_memory()
out["peak_graph_MB"] = peak / 2**20
tracemalloc.reset_peak()
ne = g.n_edges
out["edges"] = ne
parts["G"] = {"per": max(ne, 1), "columns": columns(g, (
    "edge_a", "edge_b", "edge_piece", "region_ptr", "region_pieces", "slot_ptr", "slot_piece",
    "partner_ptr", "partner_cell", "partner_slot"))}
base, _ = tracemalloc.get_traced_memory()
t = time.perf_counter()
surviving, elim = eliminate(g)
out["eliminate_s"] = time.perf_counter() - t
cur, peak = tracemalloc.get_traced_memory()
out["peak_eliminate_MB"] = (peak - base) / 2**20
tracemalloc.stop()
parts["elimination"] = {"per": max(len(elim), 1), "columns": columns(
    elim, ("cell", "piece", "round", "because")) + columns(surviving, ("alive",)),
    "python": deep(surviving, seen),
    "surviving": len(surviving)}
out["parts"] = parts
out["rss_final_MB"] = rss() / 2**20
out["peak_MB"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps(out))
"""


def run(n: int, workers: int, tiles: str, src: str) -> dict:
    env = dict(os.environ, PYTHONPATH=src)
    got = subprocess.run([sys.executable, "-c", CHILD, str(n), str(workers), tiles],
                         capture_output=True, text=True, env=env, check=False)
    if got.returncode != 0:
        raise SystemExit(f"size {n} failed: {got.stderr.strip()[-2000:]}")
    return json.loads(got.stdout.strip().splitlines()[-1])


def report(r: dict) -> None:
    print(f"\n{r['vertices']} vertices (load {r['load']:.1f} at start): {r['regions']:,} "
          f"regions, {r['cells']:,} cells, {r['pieces']:,} pieces, {r['edges']:,} edges, "
          f"{r['curves']:,} curves")
    print(f"  decompose {r['decompose_s']:.1f} s, G {r['graph_s']:.1f} s, elimination "
          f"{r['eliminate_s']:.1f} s")
    print(f"  {'held by':<14} {'per':>11} {'columns MB':>10} {'python MB':>10} "
          f"{'geos MB':>8} {'B/obj cols':>10} {'B/obj py':>9} {'B/obj geos':>10} "
          f"{'coords/obj':>10}")
    total = 0.0
    for name, p in r["parts"].items():
        cols, py, gb = p.get("columns", 0), p.get("python", 0), p.get("geos", 0)
        total += cols + py + gb
        per = p["per"]
        print(f"  {name:<14} {per:>11,} {cols / 2**20:>10.1f} {py / 2**20:>10.1f} "
              f"{gb / 2**20:>8.1f} {cols / per:>10.1f} {py / per:>9.1f} {gb / per:>10.1f} "
              f"{p.get('coords', 0) / per:>10.1f}")
    print(f"  sum of the parts {total / 2**20:.0f} MB; resident: map {r['rss_env_MB']:.0f} MB, "
          f"decomposition {r['rss_decomposition_MB']:.0f} MB, after the elimination "
          f"{r['rss_final_MB']:.0f} MB")
    print(f"  peaks: decompose {r['peak_decompose_MB']:.0f} MB, G build +"
          f"{r['peak_graph_MB']:.0f} MB (tracemalloc), elimination +"
          f"{r['peak_eliminate_MB']:.0f} MB, process {r['peak_MB']:.0f} MB")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[1000, 2000])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--tiles", default="auto", help="NXxNY or auto")
    ap.add_argument("--json", help="also write the raw rows to this file")
    ap.add_argument("--src", default=str(Path(__file__).resolve().parents[1] / "src"))
    args = ap.parse_args()
    print(f"cpus {os.cpu_count()}, load average {os.getloadavg()[0]:.1f} at start", flush=True)
    rows = []
    for n in args.sizes:
        rows.append(run(n, args.workers, args.tiles, args.src))
        report(rows[-1])
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()
