"""Benchmark: one floor plan decomposed in tiles on worker processes, then analyzed.

Run: ``python benchmarks/bench_scale.py [--sizes 1000 2000 4000] [--workers 2] [--tiles auto]
[--compare 1000 2000] [--stop-at GB] [--doc docs/scale.md]``. Each size runs in a fresh process:
``floor_plan(n, seed=0)``, ``lss = width / 15`` (the rule of ``bench_decompose.py``),
``decompose(env, lss, tiles=..., executor=process_executor(workers))``, then G and the
elimination. The workers are spawned processes: their peak resident memory is the parent's
``RUSAGE_CHILDREN`` ``ru_maxrss`` once they are shut down (the largest worker's).

Columns: vertices, tiles (``NXxNY``), workers, wall times in seconds (critical curves; tile
work: the input cut into tiles and noded by the workers, with the parts' sources; face tiles:
the parts joined, sent to the face tasks and their faces traced by the workers, retries
included; stitching: the faces and the parts' faces joined, the arrangement made; the rest of
the decomposition, and its stages: *structures*, the faces' structures numbered; *grouping*,
the faces grouped into numbered regions (specks absorbed); *chains*, the chains between
regions and their crossing candidates; *records*, the regions' polygons packed and their
cells; *piece tasks*, from there to the last pieces task's result handled (the tasks'
inputs made, the tasks, their results joined or written); *piece wait*, the part of that
the main process waited for the tasks' results; *finish*, from there to the decomposition
made (with ``--out``: the regions, cells and curves written, and the index); *result*, the
decomposition returned (with ``--out``: the store read back); G and the elimination; total;
*main CPU*, the main process's CPU seconds over all of it, its threads' included; *workers
CPU*, the worker processes' CPU seconds, all of them together, once they are shut down), peak
resident memory in MB of the main process and of the largest worker, the input segments sent
to the noding tasks over the input's count and the number of retry tasks, the parts sent to
the face tasks over the parts' count and the face retry tasks
(:mod:`tether.decomposition.tiles`), counts
(regions, cells, pieces), the verdict, and, for the sizes in ``--compare``, whether the
untiled run (its curve vertex limit lifted; its input noded as ``decompose`` does, in two
strips from 100,000 segments, :mod:`tether.decomposition.noding`, or with ``--untiled whole``
without the strips, tiled and untiled) gives the same decomposition up to renumbering: the
same counts, regions matched one to one by representative point with equal structures, the
same pieces (regions, kind, features) and the same eliminations (cell, round) in that
numbering. The untiled run is made after the tiled one
in the same process: ``main MB`` is read before it, ``untiled MB`` after it (the process's
peak with both decompositions held). The last column, ``noder``, says how the tiles noded the
input: ``float`` (GEOS's floating-point noder in every task) or ``snap F tol`` (a task's
floating-point noding failed, so every tile snap rounded the input on a grid of ``F`` curve
tolerances, as the untiled noding would: :mod:`tether.decomposition.tiles`; with the number
of grids that failed before it), ``-`` in rows measured before the column existed.

``--noding snap`` decomposes with ``noding="snap"`` (snap rounding from the start, where
GEOS's floating-point noder is known to fail: the 4,000-vertex plan). Each row is also
printed as JSON, with the main process's peak per stage (``stages``) and the largest
worker's resident memory sampled over each stage (``worker stages``, MB: between the face
tiles and the pieces' tasks, what the idle workers hold), and, where the pieces are made in
tiles (:func:`tether.decomposition.tiles.tiled_crossings`), their grid (``piece tiles``)
and the largest peak a pieces task's process reported (``piece worker MB``), and each
pieces task's CPU seconds in its worker, in tile order (``piece task CPU``: their balance).

``--out DIR`` decomposes with ``out=DIR`` (``{n}`` in ``DIR`` is replaced by the size):
the pieces and their crossings' arcs written to a store tile by tile as their tasks return
(``docs/store.md``), G and the elimination built on the store read back.

``--stop-at GB`` stops a run (its workers killed) once its main process or one of its workers
holds more than ``GB`` of resident memory (Linux): its row's verdict then says in which
stage, after how many seconds and with how much memory, and the noder column says how far
the noding had got (so a size that does not fit, forced past the memory check with
``TETHER_MEMORY_LIMIT``, cannot take the machine's memory).

``--doc FILE`` also writes the rows into the Markdown table of ``FILE`` (``docs/scale.md``)
between the lines ``<!-- bench_scale: begin -->`` and ``<!-- bench_scale: end -->``: a size
measured with a number of workers replaces its row, the others stay (if they have its
columns); each row says which command line made it. And, between ``<!-- bench_scale stages:
begin -->`` and ``<!-- bench_scale stages: end -->`` (if ``FILE`` has them), what the main
process holds: its peak resident memory over each stage (Linux's ``VmHWM``, reset as each
stage begins: the curves; the arrangement's input made; the tile work; the stitch; the face
tiles; the structures numbered; the regions grouped; the chains and candidates; the region
records; the pieces; the result made in the map's frame;
G; the elimination), the memory it holds once ``decompose`` has returned, and the counts
(the arrangement's parts and faces, regions, cells, pieces).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

CHILD = r"""
import collections, json, os, resource, sys, threading, time
import numpy as np
from tether.examples.floorplan import floor_plan
from tether.decomposition import decompose
from tether.decomposition.tiles import process_executor
from tether.analysis import analyze, build_graph

n, workers, tiles = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
compare, strips = sys.argv[4] == "1", sys.argv[5] == "strips"
stop_at = float(sys.argv[6]) * 1e9  # bytes of resident memory in one process; 0: never
noding_mode = sys.argv[7]  # decompose's noding: auto or snap
store = sys.argv[8] or None  # decompose's out: the store written tile by tile
import tether.curves
import tether.decomposition.noding as noding
import tether.decomposition.pipeline as pipeline
if not strips:  # the input noded without the strip cut, tiled and untiled
    noding.STRIP_MIN_SEGMENTS = 10**15
noder_log = {}
_noder = pipeline.tiled_noder
def _logged(tiles, executor, tol, progress=None, log=None, **kw):
    noder_log["tol"] = tol
    return _noder(tiles, executor, tol, progress, noder_log, **kw)
pipeline.tiled_noder = _logged
piece_log = {}
_crossings = getattr(pipeline, "tiled_crossings", None)  # the pieces in tiles, where made so
if _crossings is not None:
    pipeline.tiled_crossings = lambda tiles, executor, progress=None, log=None, **kw: (
        _crossings(tiles, executor, progress, piece_log, **kw))
def noder_name(log):  # float, or snap rounding's grid (in curve tolerances) and its retries
    if not log.get("float_failed"):
        if log.get("grid"):  # noding="snap": no floating-point task ran
            return f"snap {log['grid'] / log['tol']:g} tol from the start"
        return "whole" if log.get("fallback") else "float"
    k = log["snap_grids_failed"]
    return f"snap {noding.SNAP_GRIDS[k]:g} tol" + (f" ({k} grids failed)" if k else "")
env = floor_plan(n, seed=0)
lss = (env.bounds[2] - env.bounds[0]) / 15
marks = []
def _vm(key):  # this process's resident memory (VmRSS) or its peak (VmHWM), MB; Linux only
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith(key + ":"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    return None
def _reset_peak():  # VmHWM from now on (Linux: clear_refs 5)
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        pass
peaks, last = {}, [None]
def stage_peak(name):  # the main process's peak over the stage that ends now
    if last[0] is not None:
        peaks[last[0]] = max(peaks.get(last[0], 0), _vm("VmHWM") or 0)
    last[0] = name
    _reset_peak()
def progress(stage, frac):
    marks.append((stage, time.perf_counter()))
    key = ("tiles" if stage.startswith("tiles") else
           "face tiles" if stage.startswith("face tiles") else
           "pieces" if stage.startswith("piece tiles") else stage)
    if key != last[0]:
        stage_peak(key)

def _children_rss():  # the largest resident memory of this process's children, bytes (Linux)
    big = 0
    for d in os.listdir("/proc"):
        try:
            with open(f"/proc/{d}/stat") as f:
                st = f.read().rsplit(")", 1)[1].split()
            if int(st[1]) == os.getpid():
                big = max(big, int(st[21]) * os.sysconf("SC_PAGE_SIZE"))
        except (OSError, ValueError, IndexError):
            pass
    return big
wpeaks = {}  # the largest worker's resident memory over each stage, MB (sampled)
def _stopper():  # the run stopped, its row written, once a process passes stop_at
    while True:
        main, worker = (_vm("VmRSS") or 0) * 2**20, _children_rss()
        wpeaks[last[0]] = max(wpeaks.get(last[0], 0), round(worker / 2**20))
        if 0 < stop_at < max(main, worker):
            t = time.perf_counter() - w0
            row = {"vertices": n, "tiles": tiles, "workers": workers,
                   "verdict": f"stopped in {last[0]} after {t:.0f} s: main {main / 1e9:.1f} GB, "
                              f"worker {worker / 1e9:.1f} GB (--stop-at)",
                   "noder": noder_name(noder_log) if "float_failed" in noder_log else None,
                   "parts": noder_log.get("parts"), "faces": noder_log.get("faces"),
                   "stages": {k: round(v_) for k, v_ in peaks.items()},
                   "worker stages": dict(wpeaks)}
            for stage, at in marks:
                row.setdefault("at " + stage.split(" (")[0], round(at - w0, 1))
            print(json.dumps(row), flush=True)
            for pid in [d for d in os.listdir("/proc") if d.isdigit()]:
                try:
                    with open(f"/proc/{pid}/stat") as f:
                        if int(f.read().rsplit(")", 1)[1].split()[1]) == os.getpid():
                            os.kill(int(pid), 9)
                except (OSError, ValueError, IndexError):
                    pass
            os._exit(0)
        time.sleep(0.5)
ex = process_executor(workers)
w0, c0 = time.perf_counter(), time.process_time()
threading.Thread(target=_stopper, daemon=True).start()
dec = decompose(env, lss, progress=progress, tiles=tiles, executor=ex,
                noding=noding_mode, **({"out": store} if store else {}))
w1 = time.perf_counter()
ex.shutdown()
stage_peak("G")
held = _vm("VmRSS")  # the decomposition returned, held
g = build_graph(dec)
stage_peak("elimination")
v = analyze(dec, g, self_check=False, near_critical=False)
stage_peak(None)
w2 = time.perf_counter()
# the stages' peaks reset Linux's VmHWM, which ru_maxrss reads: the largest of them
main_mb = max([resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, *peaks.values()])
worker_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
at = {}
for stage, t in marks:
    key = ("tiles" if stage.startswith("tiles") else
           "face tiles" if stage.startswith("face tiles") else
           "piece tiles" if stage.startswith("piece tiles") else stage)
    at.setdefault(key, t)
    if key == "piece tiles":
        at["piece_tiles_end"] = t  # the last pieces task's result handled
    if key == "tiles":
        at["tiles_end"] = t
        shape = stage[stage.index("(") + 1:stage.index(")")]
    if key == "face tiles":
        at["face_tiles_end"] = t
if noder_log.get("strips") == 2:
    shape = "2 strips x " + shape
row = {"vertices": n, "tiles": shape, "workers": workers,
       "curves": at["arrangement"] - w0,
       "tile work": at["tiles_end"] - at["arrangement"],
       "face tiles": at["face_tiles_end"] - at["stitch"],
       "stitch": at["face structures"] - at["face_tiles_end"],
       "rest": w1 - at["face structures"],
       "structures": at["regions"] - at["face structures"],
       "grouping": at["chains"] - at["regions"],
       "chains": at["region records"] - at["chains"],
       "records": at["pieces"] - at["region records"],
       "piece tasks": at.get("piece_tiles_end", at["done"]) - at["pieces"],
       "piece wait": piece_log.get("piece_wait"),
       "finish": at["done"] - at.get("piece_tiles_end", at["done"]),
       "result": w1 - at["done"],
       "main CPU": time.process_time() - c0,
       "workers CPU": sum(resource.getrusage(resource.RUSAGE_CHILDREN)[:2]),
       "piece task CPU": piece_log.get("piece_task_cpu"),
       "G+elim": w2 - w1, "total": w2 - w0,
       "main MB": main_mb, "worker MB": worker_mb,
       "sent": noder_log["segments_sent"], "retries": noder_log["retries"],
       "face sent": noder_log["face_parts_sent"], "face retries": noder_log["face_retries"],
       "regions": len(dec.regions), "cells": len(dec.cells), "pieces": len(dec.pieces),
       "verdict": "strategy" if v.strategy_exists else "none",
       "noder": noder_name(noder_log),
       "parts": noder_log.get("parts"), "faces": noder_log.get("faces"),
       "stages": {k: round(v_) for k, v_ in peaks.items()},
       "worker stages": dict(wpeaks),
       "held": None if held is None else round(held),
       "piece tiles": "x".join(map(str, piece_log.get("piece_tiles", ()))) or None,
       "piece worker MB": round(piece_log.get("piece_worker_peak_bytes", 0) / 2**20)
       if piece_log else None}
if compare:
    tether.curves.MAX_CURVE_VERTICES = 10**12
    whole = decompose(env, lss)
    vw = analyze(whole, self_check=False, near_critical=False)
    j = dec.region_at(np.array([r.point for r in whole.regions]))
    inv = np.empty_like(j)
    inv[j] = np.arange(len(j))
    ident = np.arange(len(j))
    def pieces(d, ren):
        return collections.Counter((tuple(sorted(int(ren[r]) for r in p.regions)), p.kind,
                                    p.features) for p in d.pieces)
    def elims(d, vv, ren):
        c = d.cells
        return sorted((int(ren[c[i].region]), c[i].start_feature, c[i].end_feature, r)
                      for i, r in zip(vv.eliminated.cell.tolist(), vv.eliminated.round.tolist()))
    same = (whole.counts == dec.counts and sorted(j.tolist()) == list(range(len(j)))
            and all(r.structure == dec.regions[k].structure
                    for r, k in zip(whole.regions, j.tolist()))
            and pieces(whole, ident) == pieces(dec, inv)
            and elims(whole, vw, ident) == elims(dec, v, inv)
            and vw.strategy_exists == v.strategy_exists)
    row["equal untiled"] = "yes" if same else "NO"
    row["untiled MB"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps(row))
"""

COLUMNS = ("vertices", "tiles", "workers", "curves", "tile work", "face tiles", "stitch",
           "rest", "structures", "grouping", "chains", "records", "piece tasks", "piece wait",
           "finish", "result", "G+elim", "total", "main CPU", "workers CPU", "main MB",
           "worker MB", "sent", "retries", "face sent", "face retries", "regions", "cells",
           "pieces", "verdict", "equal untiled", "untiled MB", "noder")


def run(n: int, workers: int, tiles: str, compare: bool, untiled: str, src: str,
        stop_at: float = 0.0, noding: str = "auto", store: str = "") -> dict:
    env = dict(os.environ, PYTHONPATH=src)
    out = subprocess.run([sys.executable, "-c", CHILD, str(n), str(workers), tiles,
                          "1" if compare else "0", untiled, str(stop_at), noding,
                          store.format(n=n) if store else ""],
                         capture_output=True,
                         text=True,
                         env=env, check=False)
    if out.returncode != 0:
        return {"vertices": n, "tiles": tiles, "workers": workers,
                "verdict": "failed: " + (out.stderr.strip().splitlines() or ["?"])[-1]}
    return json.loads(out.stdout.strip().splitlines()[-1])


def fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.0f}" if v >= 100 else f"{v:.1f}"
    return str(v) if v is not None else "-"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[1000, 2000, 4000])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--tiles", default="auto", help="NXxNY or auto")
    ap.add_argument("--compare", type=int, nargs="*", default=[1000, 2000],
                    help="sizes also decomposed untiled, for equality")
    ap.add_argument("--untiled", choices=("whole", "strips"), default="strips",
                    help="how the input is noded, tiled and untiled: as decompose does "
                    "(default: two strips from 100,000 segments, each tiled on its own), or "
                    "whole (no strip cut)")
    ap.add_argument("--stop-at", type=float, default=0.0, metavar="GB",
                    help="stop a run once one of its processes holds more than GB of "
                    "resident memory (Linux), its row saying in which stage (default: never)")
    ap.add_argument("--noding", choices=("auto", "snap"), default="auto",
                    help="decompose's noding: auto (floating point, snap rounding where it "
                    "fails) or snap (snap rounding from the start)")
    ap.add_argument("--out", default="", metavar="DIR",
                    help="decompose with out=DIR ({n}: the size): the pieces written tile "
                    "by tile to a store, G and the elimination on the store read back")
    ap.add_argument("--src", default=str(Path(__file__).resolve().parents[1] / "src"))
    ap.add_argument("--doc", help="also write the rows as a Markdown table into this file")
    args = ap.parse_args()
    load = os.getloadavg()[0]
    print(f"cpus {os.cpu_count()}, load average {load:.1f} at start", flush=True)
    print("  ".join(f"{c:>9}" for c in COLUMNS), flush=True)
    rows = []
    for n in args.sizes:
        row = run(n, args.workers, args.tiles, n in args.compare, args.untiled, args.src,
                  args.stop_at, args.noding, args.out)
        rows.append(row)
        print("  ".join(f"{fmt(row.get(c)):>9}" for c in COLUMNS), flush=True)
        print(json.dumps(row), flush=True)  # every measure, the stages' included
    if args.doc:
        write_doc(Path(args.doc), rows, " ".join(sys.argv[1:]), load)
        write_stages(Path(args.doc), rows, " ".join(sys.argv[1:]), load)


BEGIN, END = "<!-- bench_scale: begin -->", "<!-- bench_scale: end -->"
STAGES_BEGIN, STAGES_END = ("<!-- bench_scale stages: begin -->",
                            "<!-- bench_scale stages: end -->")

#: The per-stage table's stage columns: (progress stage, column title).
STAGES = (("critical curves", "curves"), ("arrangement", "input"), ("tiles", "tile work"),
          ("stitch", "stitch"), ("face tiles", "face tiles"),
          ("face structures", "structures"), ("regions", "regions"), ("chains", "chains"),
          ("region records", "records"), ("pieces", "pieces"),
          ("done", "to result"), ("G", "G"), ("elimination", "elim"))
STAGE_COUNTS = ("vertices", "workers", "parts", "faces", "regions", "cells", "pieces")


def _old_rows(block: str, cols: tuple[str, ...]) -> list[list[str]]:
    """The rows of the Markdown table in ``block`` in the columns ``cols``, read by the
    table's own header (a name twice, a count and a stage: by its occurrence): a column it
    lacks (measured before the column existed) is ``-``."""
    header, rows = None, []
    for ln in block.splitlines():
        cells = [c.strip() for c in ln.strip().strip("|").split("|")]
        if cells[0] == cols[0]:
            header = _numbered(cells)
        elif header is not None and len(cells) == len(header) and cells[0].isdigit():
            got = dict(zip(header, cells, strict=True))
            rows.append([got.get(c, "-") for c in _numbered(cols)])
    return rows


def _numbered(names: Sequence[str]) -> list[tuple[str, int]]:
    """Each name with the number of times it came before."""
    seen: dict[str, int] = {}
    out = []
    for c in names:
        out.append((c, seen.get(c, 0)))
        seen[c] = seen.get(c, 0) + 1
    return out


def write_doc(path: Path, rows: list[dict], argv: str, load: float) -> None:
    """The rows as a Markdown table between :data:`BEGIN` and :data:`END` in ``path``: rows of
    the sizes and worker counts measured replace those of the same, the others are kept (if
    they have this table's columns), each row with the command line and the load average of
    its run."""
    text = path.read_text()
    head, rest = text.split(BEGIN, 1)
    block, tail = rest.split(END, 1)
    cols = (*COLUMNS, "run")
    old = {(int(c[0]), int(c[2])): c for c in _old_rows(block, cols)}
    run_note = f"`bench_scale.py {argv}`, load {load:.1f}"
    if "--untiled whole" in argv:
        run_note += " (no strips)"
    for r in rows:
        old[int(r["vertices"]), int(r["workers"])] = [fmt(r.get(c)) for c in COLUMNS] + [run_note]
    lines = [BEGIN, "", f"Measured on {os.cpu_count()} CPUs shared with other sessions (the "
             "load average at the start of each run is given: above 2, the times are "
             "inflated).", "", "| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(old[k]) + " |" for k in sorted(old)]
    lines += ["", ""]
    path.write_text(head + "\n".join(lines) + END + tail)


def write_stages(path: Path, rows: list[dict], argv: str, load: float) -> None:
    """The main process's peak resident memory per stage (MB; Linux's ``VmHWM``, reset at
    each stage), the memory it holds once ``decompose`` returns (*held*) and the counts, as a
    Markdown table between :data:`STAGES_BEGIN` and :data:`STAGES_END` in ``path`` (if it
    has them): rows of the sizes and worker counts measured replace those of the same."""
    text = path.read_text()
    if STAGES_BEGIN not in text:
        return
    head, rest = text.split(STAGES_BEGIN, 1)
    block, tail = rest.split(STAGES_END, 1)
    cols = (*STAGE_COUNTS, *(t for _, t in STAGES), "held", "run")
    old = {(int(c[0]), int(c[1])): c for c in _old_rows(block, cols)}
    for r in rows:
        if "stages" not in r:  # refused or failed: no stage measured
            continue
        st = r["stages"]
        old[int(r["vertices"]), int(r["workers"])] = (
            [fmt(r.get(c)) for c in STAGE_COUNTS] + [fmt(st.get(k)) for k, _ in STAGES]
            + [fmt(r.get("held")), f"`bench_scale.py {argv}`, load {load:.1f}"])
    lines = [STAGES_BEGIN, "", "| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(old[k]) + " |" for k in sorted(old)]
    lines += ["", ""]
    path.write_text(head + "\n".join(lines) + STAGES_END + tail)


if __name__ == "__main__":
    main()
