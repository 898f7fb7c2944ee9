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

def packed(holder):
    # the bytes of the WKB column a holder keeps its geometries in (None: it holds them
    # decoded, as shapely objects; checkouts before the packing)
    got = holder.held_wkb(0, len(holder)) if hasattr(holder, "held_wkb") else None
    return None if got is None else got[0].nbytes + got[1].nbytes

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
cols = columns(structs, ("ptr", "pairs", "region"))
got = packed(shapes)
if got is not None:  # packed as WKB: its bytes are columns, no geometry to measure
    unions = shapes.held_unions()
    cols += got + (0 if unions is None else columns(unions, ("ids", "ptr", "raw", "fptr")))
    g_b = g_c = g_n = 0
else:
    held, _ = shapes.held()
    faces = [f for fs in shapes.pending_unions().values() for f in fs]
    g_b, g_c, g_n = geos(list(held) + faces)
if lean:
    cols += columns(regs._table, ("area", "point"))
parts["regions"] = {"per": nr, "columns": cols, "python": py + deep(structs._sets, seen),
                    "geos": g_b, "coords": g_c, "geoms": g_n}
table = dec.cells._table
parts["cells"] = {"per": nc, "columns": columns(table, ("region", "start", "end", "first")),
                  "python": deep(table.names, seen)}
pt = dec.pieces._table
got = packed(pt.shapes)
if got is not None:
    g_b = g_c = g_n = 0
else:
    pg, _ = pt.shapes.held()
    g_b, g_c, g_n = geos(pg)
parts["pieces"] = {"per": npc, "columns": columns(pt, ("pair", "q", "n", "eps", "ok", "desc"))
                   + (got or 0), "python": deep(pt.descs, seen), "geos": g_b, "coords": g_c,
                   "geoms": g_n}
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
    "partner_ptr", "partner_slot"))}  # (partner_cell: made when read, not held)
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


#: The per-object figures of the doc's table: (column, parts summed, per which count)
_PER = (("B/region", ("regions",), "regions"), ("B/cell", ("cells",), "cells"),
        ("B/piece", ("pieces",), "pieces"), ("arcs B/piece", ("crossing arcs",), "pieces"),
        ("B/edge", ("G",), "edges"), ("B/elim.", ("elimination",), "cells"))


def _bytes(r: dict, parts: tuple[str, ...]) -> float:
    return sum(r["parts"][p].get(k, 0) for p in parts for k in ("columns", "python", "geos"))


def _table(rows: list[dict]) -> list[str]:
    head = ["run", "vertices", "regions", "cells", "pieces", "edges",
            *[c for c, _, _ in _PER], "decomposition MB", "after elim. MB", "G build + MB",
            "elim. + MB", "peak MB", "load"]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        per = [f"{_bytes(r, parts) / max(r[n], 1):.0f}" for _, parts, n in _PER]
        out.append("| " + " | ".join([
            r["label"], f"{r['vertices']:,}", f"{r['regions']:,}", f"{r['cells']:,}",
            f"{r['pieces']:,}", f"{r['edges']:,}", *per, f"{r['rss_decomposition_MB']:,.0f}",
            f"{r['rss_final_MB']:,.0f}", f"{r['peak_graph_MB']:,.0f}",
            f"{r['peak_eliminate_MB']:,.0f}", f"{r['peak_MB']:,.0f}",
            f"{r['load']:.1f}"]) + " |")
    return out


def _projection(rows: list[dict], label: str, src: str) -> list[str]:
    """The counts and the main process's holdings at twice the largest size measured with
    ``label``: each count grown as over the last doubling, times the change in the growth of
    what drives it in the memory estimate (``P`` pairs within lss for regions, pieces and
    curves; ``P**2 / n`` for cells and edges), the bytes per object of the largest run."""
    sys.path.insert(0, src)
    from tether.curves.budget import estimate_memory
    from tether.examples.floorplan import floor_plan

    mine = sorted((r for r in rows if r["label"] == label), key=lambda r: r["vertices"])
    if len(mine) < 2:
        return []
    a, b = mine[-2], mine[-1]
    sizes = (a["vertices"], b["vertices"], 2 * b["vertices"])
    est = []
    for n in sizes:
        env = floor_plan(n, seed=0)
        e = estimate_memory(env, (env.bounds[2] - env.bounds[0]) / 15)
        est.append((e.pairs, e.cells))
    grow_p = (est[2][0] / est[1][0]) / (est[1][0] / est[0][0])
    grow_c = (est[2][1] / est[1][1]) / (est[1][1] / est[0][1])
    count = {k: b[k] * (b[k] / a[k]) * (grow_c if k in ("cells", "edges") else grow_p)
             for k in ("regions", "cells", "pieces", "edges", "curves")}
    held = {name: _bytes(b, (name,)) / max(b[n], 1) * count[n] for name, n in (
        ("regions", "regions"), ("cells", "cells"), ("pieces", "pieces"),
        ("crossing arcs", "pieces"), ("curves", "curves"), ("G", "edges"),
        ("elimination", "cells"))}
    geos = sum(b["parts"][k].get("geos", 0) / max(b[n], 1) * count[n]
               for k, n in (("regions", "regions"), ("pieces", "pieces")))
    dec = sum(v for k, v in held.items() if k not in ("G", "elimination"))
    g_build = b["peak_graph_MB"] * 2**20 / b["edges"] * count["edges"]
    g_elim = held["G"] + b["peak_eliminate_MB"] * 2**20 / b["cells"] * count["cells"]
    gb = 2.0**30
    n2 = sizes[2]
    return [
        f"Projected at {n2:,} vertices from the `{label}` runs at {sizes[0]:,} and "
        f"{sizes[1]:,} (pairs within lss P = {est[0][0]:,}, {est[1][0]:,}, {est[2][0]:,}: "
        f"each count grown as over the last doubling, times {grow_p:.3f} for regions, "
        f"pieces and curves, which follow P, and {grow_c:.3f} for cells and edges, which "
        f"follow P²/n): about {count['regions']:,.0f} regions, {count['cells']:,.0f} cells, "
        f"{count['pieces']:,.0f} pieces and {count['edges']:,.0f} edges of G. At the bytes "
        f"per object of {sizes[1]:,} vertices, the finished decomposition holds "
        f"{dec / gb:.1f} GB ({geos / gb:.1f} GB of it the regions' and pieces' shapely "
        f"geometries, {held['crossing arcs'] / gb:.1f} GB the crossings' arcs), G "
        f"{held['G'] / gb:.1f} GB, the eliminations {held['elimination'] / gb:.2f} GB; the "
        f"build of G peaks {g_build / gb:.1f} GB above the decomposition, the elimination "
        f"{g_elim / gb:.1f} GB (G included). Analyzed from a store (`tether analyze --from "
        f"DIR`), no geometry is read: at most about "
        f"{(dec - geos + max(g_build, g_elim)) / gb:.1f} GB in all, before the "
        "map and the interpreter (~50 MB; geometry held packed is counted in the bytes per "
        "object, and a store read for analysis does not read it)."]


def _estimates(rows: list[dict], label: str, src: str) -> list[str]:
    """The tiled estimate (``tether.curves.budget``, the calling process's peak as
    ``decompose(..., tiles="auto")`` checks it, from the map alone) against the measured
    peaks of the rows of ``label``, and its projection at twice the largest size."""
    sys.path.insert(0, src)
    from tether.curves.budget import AUTO_PLAN, _tiled, estimate_memory
    from tether.examples.floorplan import floor_plan

    mine = sorted((r for r in rows if r["label"] == label), key=lambda r: r["vertices"])
    if not mine:
        return []
    out = ["| vertices | pairs P | tiles | main estimate MB | main measured MB | ratio | "
           "decompose stage MB | G + elimination stage MB | worker estimate MB |",
           "|---|---|---|---|---|---|---|---|---|"]
    sizes = [r["vertices"] for r in mine] + [2 * mine[-1]["vertices"]]
    for n in sizes:
        env = floor_plan(n, seed=0)
        lss = (env.bounds[2] - env.bounds[0]) / 15
        est = estimate_memory(env, lss)
        t = _tiled(env, est, AUTO_PLAN)
        got = next((r for r in mine if r["vertices"] == n), None)
        mb = 2.0**20
        out.append("| " + " | ".join([
            f"{n:,}", f"{est.pairs:,}", f"{t.tiles}", f"{t.main / mb:,.0f}",
            "-" if got is None else f"{got['peak_MB']:,.0f}",
            "-" if got is None else f"{t.main / mb / got['peak_MB']:.2f}",
            f"{t.decompose / mb:,.0f}", f"{t.analysis / mb:,.0f}",
            f"{t.worker / mb:,.0f}"]) + " |")
    return out


JSON_NOTE = """\
## `analyze --json` of a large result

`Verdict.to_dict()` (what `tether analyze --json` prints) gives a list longer than
`tether.analysis.elimination.JSON_LIST_MAX` (200,000) items (the edges of G, the surviving
cells, the eliminations) as `{"count": n, "arrays": FILE}` instead of one JSON value an item
(~300 bytes of Python objects an edge: tens of GB at 4,000 vertices); `--arrays FILE.npz`
(`Verdict.save_arrays`) writes those lists as integer columns (`edge_a`, `edge_b`,
`edge_piece`, `surviving`, `eliminated_cell`, `eliminated_piece`, `eliminated_round`,
`eliminated_because`, with the cells' `cell_region`, `cell_start`, `cell_end` codes into
`feature_names`). Smaller results print as before."""


BEGIN, END = "<!-- bench_memory: begin -->", "<!-- bench_memory: end -->"


def write_doc(path: Path, rows: list[dict], label: str, src: str) -> None:
    """The section (heading, text, the runs' table and the projection) between
    :data:`BEGIN` and :data:`END` in ``path`` (appended at its end the first time)."""
    text = path.read_text()
    body = "\n".join([BEGIN, SECTION, *_table(rows), "", *_projection(rows, label, src), "",
                      ESTIMATE, *_estimates(rows, label, src), "", ESTIMATE_AFTER, "",
                      JSON_NOTE, END])
    if BEGIN in text:
        head, rest = text.split(BEGIN, 1)
        text = head + body + rest.split(END, 1)[1]
    else:
        text = text.rstrip("\n") + "\n\n" + body + "\n"
    path.write_text(text)


SECTION = """## What the main process holds per region, cell, piece and edge

Measured by `python benchmarks/bench_memory.py --sizes 1000 2000 --label LABEL --runs
docs/memory_lean_runs.json --doc docs/memory.md` (the rows below; `--src DIR` measures
another checkout, as the rows of main before the lean results were). Floor plans
`floor_plan(n, seed=0)`, lss = width / 15, decomposed in tiles on two worker processes; the
bytes are those the finished `Decomposition`, `ConnectivityGraph` and eliminations hold in
the main process, per object: numpy columns (`nbytes`), Python objects (`sys.getsizeof` over
their graph) and shapely geometries (the resident memory an equal copy made from WKB takes).
*B/piece* counts the pieces' columns and lines, *arcs B/piece* the free arcs kept at both
sides of each piece's crossing (for G and the store), *B/elim.* the eliminations and the
surviving set per cell. *decomposition MB* is the resident memory the decomposition adds,
*after elim.* the process's resident memory once G and the eliminations are made, *G build +*
and *elim. +* the `tracemalloc` peaks of those two steps above what was held, *peak* the
process's peak resident memory (the decomposition's own, in tiles, is most of it).

The lean representation (`tether.decomposition.model.Regions`, `RegionTable`; the cells'
and G's columns in int32/int16; `tether.analysis.elimination.CellSet`): a region is its
area, point and structure id in columns, its `Region` record made when read; cells are
three small int columns; G is int32 CSR arrays found for runs of ~1 million arc rows at a
time (`EDGE_CHUNK_ROWS`), the elimination reads each round's partner entries in runs of ~4
million (`ELIM_CHUNK`); the surviving cells are one bool a cell; a store read for analysis
decodes no geometry and makes no curve (`docs/store.md`). The projection below scales every
figure of the largest run by its count, the runs' temporaries included: an upper bound
for the steps done run by run.

Since the rows `lean2`: the regions' polygons and the pieces' lines are held packed as WKB
(one byte column and offsets, `tether.decomposition.views.wkb_column`: every double kept,
~16 bytes a coordinate) and decoded on their first read, never as shapely objects (~1 KB
each: the column *geos* is then 0, the bytes counted as columns); G's edges are found run
by run from the crossings' arc table as held (no sorted copy of every row) and its partner
entries placed by a counting sort, runs of 2**18 edges at a time (`PARTNER_CHUNK`: no sort
of every entry).
"""

ESTIMATE = """## The estimate of a decomposition in tiles

`decompose(..., tiles=...)` (`--tiles`, `--workers`, `--dask`) checks the estimate of the
tiled path (`tether.curves.budget.estimate_tiled`) for each process, before any work and
again after the critical intervals, in one line with what would fit (more tiles, an `lss`,
a curve tolerance; an untiled refusal also names `--tiles auto` when that fits). The calling
process holds the result, G and the elimination, whatever the tiles: its peak is the larger
of its `decompose` stage (what the result holds plus 1,314 bytes a polyline vertex of
temporaries) and its G and elimination stage (the result, G at 39.5 bytes an edge, and the
larger of G's build, 58 bytes an edge, and the elimination, 84 bytes a cell), from counts
projected from the pairs within lss `P` (regions and pieces grow as `P^1.12` and `P^1.11`,
cells and edges as `(P²/n)^0.93` from the run at 2,000 vertices) at the bytes per object of
that run (`tether.curves.budget.TILED`, each constant with its source); a worker's is 100 MB
and 3.7 KB a segment of its tile's input (the largest worker's 1,117 MB at 2,000 vertices in
`docs/scale.md`). Both are raised by 10 %. The estimate (from the map alone, as checked
before any work) against the measured peaks of the calling process (the column *peak MB*
above), and at twice the largest size:
"""

ESTIMATE_AFTER = """\
At 1,000 vertices the estimate is above the measured peak (its per-vertex term is fitted at
2,000, where the temporaries per vertex are larger); its worker figure is above the 413 MB
measured at 1,000 vertices (`docs/scale.md`). At 4,000 vertices the calling process is
projected over 4 GB, set by what it holds (the result with the crossings' arcs, G, the
elimination's columns), not by the tiles: refused with a 4 GB budget, accepted on this
machine's 23 GB. `analyze` near a critical length decomposes the map twice more (in the same
tiles, `analyze(..., tiles=...)`; the command passes its `--tiles`) while the first result
and G are held: the estimate does not include those."""




def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="*", default=[1000, 2000],
                    help="floor-plan sizes to measure (none: only rewrite --doc from --runs)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--tiles", default="auto", help="NXxNY or auto")
    ap.add_argument("--json", help="also write the raw rows to this file")
    ap.add_argument("--label", default="this checkout", help="the rows' name in --runs")
    ap.add_argument("--runs", help="merge the rows into this JSON file (by label and size)")
    ap.add_argument("--doc", help="write the --runs rows and a projection into this "
                    "Markdown file (between its bench_memory markers)")
    ap.add_argument("--src", default=str(Path(__file__).resolve().parents[1] / "src"))
    args = ap.parse_args()
    print(f"cpus {os.cpu_count()}, load average {os.getloadavg()[0]:.1f} at start", flush=True)
    rows = []
    for n in args.sizes:
        rows.append(dict(run(n, args.workers, args.tiles, args.src), label=args.label))
        report(rows[-1])
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1) + "\n")
    if args.runs:
        path = Path(args.runs)
        old = json.loads(path.read_text()) if path.exists() else []
        keys = {(r["label"], r["vertices"]) for r in rows}
        merged = [r for r in old if (r["label"], r["vertices"]) not in keys] + rows
        path.write_text(json.dumps(merged, indent=1) + "\n")
        if args.doc:
            write_doc(Path(args.doc), merged, args.label, args.src)


if __name__ == "__main__":
    main()
