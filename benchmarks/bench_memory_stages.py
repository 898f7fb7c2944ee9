"""Benchmark: the main process's memory in the curves stage, family by family, and (with
``--decompose``) its peak in every stage of a tiled decomposition (issue 25).

Run: ``python benchmarks/bench_memory_stages.py [--sizes 1000 2000] [--decompose] [--src DIR]
[--label LABEL] [--runs docs/memory_stage_runs.json] [--doc docs/memory.md]``. Each size runs
in a fresh process: ``floor_plan(n, seed=0)``, ``lss = width / 15`` (the rule of
``bench_scale.py``). The curves stage is run as :func:`tether.curves.critical_curves` runs
it, on the internal map, with the process's resident memory read after each family
(Linux's ``VmRSS``) and its peak over each step (``VmHWM``, reset as each step begins): the
candidate families made, each family's critical intervals, the polylines drawn, the curves
made and their straight lines shared. The columns: the peak over the stage, the resident
memory once the curves are made (*held*), the polyline vertices, and the peak less the
process's memory before the stage (the map loaded) per polyline vertex. With
``--decompose`` the same size is also decomposed in tiles on two workers and analyzed by
``bench_scale.py``'s measuring child (its per-stage peaks: ``VmHWM`` reset as each stage
begins). ``--src`` measures another checkout (e.g. ``/work/main/src``, the code before a
change); ``--runs`` keeps the rows (merged by label, size and kind) and ``--doc`` writes them
between the lines ``<!-- bench_memory stages: begin -->`` and ``<!-- bench_memory stages:
end -->`` of the file (appended the first time).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

CHILD = r"""
import json, sys, time
from tether.examples.floorplan import floor_plan
from tether.curves import (candidate_families, critical_intervals, off_walls, wall_band,
                           overshoot_family, vertex_estimates, draw_all, share_lines)
from tether.curves.families import Curve
from tether.tolerances import REL_CURVE_TOL
from tether._util.memory import release_memory
import inspect

def vm(key):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1]) / 1024

def reset():
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")

n = int(sys.argv[1])
env0 = floor_plan(n, seed=0)
lss = (env0.bounds[2] - env0.bounds[0]) / 15 * env0.frame.scale
env = env0.internal
steps, t0 = [], time.perf_counter()
base = vm("VmRSS")
reset()
def step(name):
    global t0
    steps.append({"step": name, "rss": round(vm("VmRSS")), "peak": round(vm("VmHWM")),
                  "seconds": round(time.perf_counter() - t0, 2)})
    reset()
    t0 = time.perf_counter()
tol = REL_CURVE_TOL * env.diameter
fams = candidate_families(env, lss)
step("families")
found, walls, first = [], None, env.coincident
trims = "release_memory()" in inspect.getsource(sys.modules["tether.curves"])
for fam in fams:
    ivs = critical_intervals(env, fam)
    if fam.kind == "B":
        ivs = [iv if first[c] == c else [] for c, iv in enumerate(ivs)]
    if fam.kind in "ACD":
        walls = wall_band(env) if walls is None else walls
        ivs = off_walls(fam, ivs, walls)
    found += overshoot_family(fam, ivs, 20 * tol)
    if trims:  # as this checkout's critical_curves does
        release_memory()
    step(f"intervals {fam.kind} ({len(fam):,} curves)")
est = vertex_estimates(found, tol)
if "estimates" in inspect.signature(draw_all).parameters:
    drawn_all = draw_all(found, tol, est)
else:
    drawn_all = draw_all(found, tol)
step("polylines drawn")
curves = []
for (fam, c, ivs), drawn in zip(found, drawn_all, strict=True):
    curves.append(Curve(len(curves), fam.kind, fam.features[c], (fam.lo[c], fam.hi[c]),
                        tuple(ivs), tuple(p for _, p in drawn), tuple(t for t, _ in drawn),
                        fam, c))
del drawn_all
curves = share_lines(curves, env.length_tol)
step("curves made, lines shared")
vertices = sum(len(p) for c in curves for p in c.polylines)
print(json.dumps({"base": round(base), "steps": steps, "vertices": vertices,
                  "curves": len(curves)}))
"""


def commit(src: str) -> str:
    """The short commit of the checkout holding ``src`` (``?`` if unknown)."""
    out = subprocess.run(["git", "-C", src, "rev-parse", "--short", "HEAD"],
                         capture_output=True, text=True, check=False)
    return out.stdout.strip() or "?"


def curves_run(n: int, src: str) -> dict:
    """The curves stage of ``floor_plan(n)`` measured in a fresh process."""
    out = subprocess.run([sys.executable, "-c", CHILD, str(n)], capture_output=True,
                         text=True, env=dict(os.environ, PYTHONPATH=src), check=True)
    r = json.loads(out.stdout.strip().splitlines()[-1])
    peak = max(s["peak"] for s in r["steps"])
    return dict(r, kind="curves", vertices_map=n, peak=peak, held=r["steps"][-1]["rss"],
                seconds=round(sum(s["seconds"] for s in r["steps"]), 1),
                bytes_per_vertex=round((peak - r["base"]) * 2**20 / r["vertices"]))


def decompose_run(n: int, src: str) -> dict:
    """A tiled decomposition of ``floor_plan(n)`` on two workers and its analysis, measured
    by ``bench_scale.py``'s child (its per-stage peaks of the main process)."""
    import bench_scale

    r = bench_scale.run(n, 2, "auto", False, "strips", src)
    return dict(r, kind="decompose", vertices_map=n)


BEGIN, END = "<!-- bench_memory stages: begin -->", "<!-- bench_memory stages: end -->"

STAGES = (("critical curves", "curves"), ("arrangement", "input"), ("tiles", "tile work"),
          ("stitch", "stitch"), ("face tiles", "face tiles"),
          ("face structures", "structures"), ("regions", "regions"), ("pieces", "pieces"),
          ("done", "to result"), ("G", "G"), ("elimination", "elim"))

TEXT = """## The main process's peak stage by stage

Measured by `python benchmarks/bench_memory_stages.py --sizes 1000 2000 [--decompose]
--label LABEL --runs docs/memory_stage_runs.json --doc docs/memory.md` (`--src DIR`: another
checkout, as the rows of main before the change). Floor plans `floor_plan(n, seed=0)`, lss =
width / 15. Resident memory in MB (Linux: `VmRSS`; the peaks `VmHWM`, reset as each step
begins); *load* the load average at the run's start (2 CPUs shared with other sessions:
above 2 the times are inflated, the memory is not).

The curves stage (`tether.curves.critical_curves`), family by family: *peak* over the stage,
*held* once the curves are made, the polyline vertices, and *B/vertex* the peak less the
process's memory before the stage (the map loaded) per polyline vertex. Its peak was set by
the conchoids' (E) critical intervals, all their semi-free samples at once (2.9 million at
2,000 vertices, ~4 times that at 4,000), and by the D lines' distance matrix of every pair
of poles: not by the polylines. The curves are now taken in blocks of about
`tether.curves.critical.SAMPLE_BLOCK` samples, drawn in blocks of about
`tether.curves.draw.DRAW_BLOCK` vertices, the pole pairs a block of rows at a time, and the
heap is trimmed after each family (the same curves, bit for bit):
"""

DECOMPOSE_TEXT = """
A decomposition in tiles on two workers and its analysis (`--decompose`: the measuring child
of `benchmarks/bench_scale.py`), the main process's peak over each stage and what it holds
once `decompose` has returned (*held*). Besides the curves: the structures stage finds its
structure ids without the grid of every face's cells padded to the longest
(`tether.decomposition.structure`: the grid's row hash made column by column, rows times the
longest row of int64 before), the regions stage builds the segment grid of its clearance
search with fewer temporaries (`tether.spatial`), and the cells' columns are made in the
cell table's int32 and int16 types (no int64 copy of three columns held to the end of
`decompose`: 24 bytes a cell). The regions stage's peak is still its clearance search
(`tether.decomposition.pieces.part_candidates`: two segment grids of up to 16 entries a
segment), the pieces stage's is the decomposition's. The stage peaks before these changes,
at e35e25b, are in `docs/scale.md` (its stage table: curves 235 and 774 MB, structures 346
and 1,024 MB, regions 653 and 1,723 MB, pieces 669 and 2,354 MB at 1,000 and 2,000
vertices, measured under another load):
"""


def _fmt(v) -> str:
    return f"{v:,}" if isinstance(v, int) else str(v)


def write_doc(path: Path, rows: list[dict]) -> None:
    """The rows' tables between :data:`BEGIN` and :data:`END` in ``path``."""
    curves = sorted((r for r in rows if r["kind"] == "curves"),
                    key=lambda r: (r["vertices_map"], r["label"]))
    steps = [s["step"].split(" (")[0] for s in curves[0]["steps"]] if curves else []
    lines = [BEGIN, TEXT, "| run | vertices | " + " | ".join(steps)
             + " | peak | held | polyline vertices | B/vertex | seconds | load |",
             "|" + "---|" * (len(steps) + 8)]
    for r in curves:
        lines.append(f"| {r['label']} {r['commit']} | {r['vertices_map']:,} | "
                     + " | ".join(_fmt(s["peak"]) for s in r["steps"])
                     + f" | {r['peak']:,} | {r['held']:,} | {r['vertices']:,} | "
                       f"{r['bytes_per_vertex']:,} | {r['seconds']} | {r['load']:.1f} |")
    dec = sorted((r for r in rows if r["kind"] == "decompose" and "stages" in r),
                 key=lambda r: (r["vertices_map"], r["label"]))
    if dec:
        lines += [DECOMPOSE_TEXT, "| run | vertices | " + " | ".join(t for _, t in STAGES)
                  + " | held | main MB | worker MB | load |", "|" + "---|" * (len(STAGES) + 6)]
        for r in dec:
            st = r["stages"]
            lines.append(f"| {r['label']} {r['commit']} | {r['vertices_map']:,} | "
                         + " | ".join(_fmt(st.get(k, "-")) for k, _ in STAGES)
                         + f" | {r['held']:,} | {round(r['main MB']):,} | "
                           f"{round(r['worker MB']):,} | {r['load']:.1f} |")
    lines += ["", END]
    text = path.read_text()
    if BEGIN in text:
        head, rest = text.split(BEGIN, 1)
        text = head + "\n".join(lines) + rest.split(END, 1)[1]
    else:
        text = text.rstrip("\n") + "\n\n" + "\n".join(lines) + "\n"
    path.write_text(text)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="*", default=[1000, 2000],
                    help="floor-plan sizes to measure (none: only rewrite --doc from --runs)")
    ap.add_argument("--decompose", action="store_true",
                    help="also measure a tiled decomposition's stages (bench_scale's child)")
    ap.add_argument("--label", default="this checkout", help="the rows' name")
    ap.add_argument("--runs", help="merge the rows into this JSON file (label, size, kind)")
    ap.add_argument("--doc", help="write the --runs rows into this Markdown file")
    ap.add_argument("--src", default=str(Path(__file__).resolve().parents[1] / "src"))
    args = ap.parse_args()
    rows = []
    for n in args.sizes:
        kinds = (curves_run, decompose_run) if args.decompose else (curves_run,)
        for measure in kinds:
            load = os.getloadavg()[0]
            r = dict(measure(n, args.src), label=args.label, commit=commit(args.src),
                     load=round(load, 1))
            print(json.dumps({k: v for k, v in r.items() if k != "steps"}), flush=True)
            rows.append(r)
    if args.runs:
        path = Path(args.runs)
        old = json.loads(path.read_text()) if path.exists() else []
        keys = {(r["label"], r["vertices_map"], r["kind"]) for r in rows}
        rows = [r for r in old if (r["label"], r["vertices_map"], r["kind"]) not in keys] + rows
        path.write_text(json.dumps(rows, indent=1) + "\n")
    if args.doc:
        write_doc(Path(args.doc), rows)


if __name__ == "__main__":
    main()
