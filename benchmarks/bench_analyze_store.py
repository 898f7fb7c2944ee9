"""Benchmark: ``tether analyze --from DIR`` step by step, its time and memory.

Run: ``python benchmarks/bench_analyze_store.py DIR [DIR ...] [--src SRC]``. For each store
(``docs/store.md``; written by ``tether decompose ... --out DIR``) a fresh process reads it
(``read_decomposition``) and analyzes it as ``tether analyze --from DIR`` does, without the
near-critical verdicts and, unless ``--self-check``, without the self-check
(``self_check=False, near_critical=False``: G and the elimination). It prints one row per
step: the wall time in seconds and the process's peak resident memory in MB over the step
(Linux's ``VmHWM``, reset as each step begins; also sampled every 20 ms from a thread, the
``sampled`` column), then the counts and the verdict.

The steps are those ``analyze`` reports through its ``progress`` argument: ``load`` (the
store's index and columns read: regions, cells, pieces, no geometry), ``cells index`` (the
cells' sorted keys, to find a cell from its region and arc ends), ``G edges`` (the arc pairs
of both sides of every piece's crossing, the store's parts read one at a time), ``G slots``
(G's slots and partner lists), ``elimination`` (the fixed point) and ``verdict`` (the
witness). ``--src`` runs another checkout's ``src``; where its ``analyze`` takes no
``progress`` the row is ``G + elimination`` as one step. ``--doc FILE`` writes the
last store's table into ``FILE`` (``docs/store.md``) between the lines
``<!-- bench_analyze_store: begin -->`` and ``<!-- bench_analyze_store: end -->``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

CHILD = r"""
import inspect, json, sys, threading, time
store, self_check = sys.argv[1], sys.argv[2] == "1"

def _vm(key):  # this process's VmRSS or VmHWM, MB (Linux), else None
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith(key + ":"):
                    return int(line.split()[1]) / 1024
    except OSError:
        return None

def _reset_peak():  # VmHWM counted from now on (Linux: clear_refs 5)
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        pass

rows, current = [], {}
def step(name):  # the step that ends now recorded; ``name`` begins (None: the last ends)
    now = time.perf_counter()
    if current:
        current["s"] = now - current.pop("t0")
        current["MB"] = _vm("VmHWM")
        rows.append(dict(current))
        current.clear()
    if name is not None:
        _reset_peak()
        current.update(step=name, t0=now, sampled=_vm("VmRSS") or 0.0)

def sampler():
    while True:
        if current:
            current["sampled"] = max(current.get("sampled", 0.0), _vm("VmRSS") or 0.0)
        time.sleep(0.02)

threading.Thread(target=sampler, daemon=True).start()
step("imports")
from tether.analysis import analyze
from tether.decomposition.store import read_decomposition
step("load")
dec = read_decomposition(store)
kw = dict(self_check=self_check, near_critical=False)
if "progress" in inspect.signature(analyze).parameters:
    def progress(stage, frac):
        if stage == "done":
            step(None)
        elif not current or current["step"] != stage:
            step(stage)
    v = analyze(dec, progress=progress, **kw)
else:
    step("G + elimination")
    v = analyze(dec, **kw)
    step(None)
if current:
    step(None)
c = v.counts()
print(json.dumps({"rows": rows, "regions": c["regions"], "cells": c["cells"],
                  "pieces": len(dec.pieces), "edges": c["edges"],
                  "surviving": c["surviving_cells"], "eliminated": len(v.eliminated),
                  "verdict": "strategy" if v.strategy_exists else "none"}))
"""


def run(store: str, src: str, self_check: bool = False) -> dict:
    """One store analyzed in a fresh process: its steps' rows and counts."""
    env = dict(os.environ, PYTHONPATH=src)
    out = subprocess.run([sys.executable, "-c", CHILD, store, "1" if self_check else "0"],
                         capture_output=True, text=True, env=env, check=False)
    if out.returncode != 0:
        raise SystemExit(f"{store}: " + (out.stderr.strip().splitlines() or ["failed"])[-1])
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    """Print the table of each store."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("stores", nargs="+", metavar="DIR")
    ap.add_argument("--src", default=str(Path(__file__).resolve().parents[1] / "src"))
    ap.add_argument("--doc", help="also write the last store's table into this Markdown "
                    "file (docs/store.md) between the lines " + BEGIN + " and " + END)
    ap.add_argument("--self-check", action="store_true",
                    help="also run analyze's self-check (the step 'self-check': it reads "
                    "and samples the regions' polygons), as 'tether analyze --from' does")
    args = ap.parse_args()
    load = os.getloadavg()[0]
    print(f"cpus {os.cpu_count()}, load average {load:.1f} at start", flush=True)
    for store in args.stores:
        got = run(store, args.src, args.self_check)
        if args.doc:
            write_doc(Path(args.doc), got, " ".join("DIR" if a == store else a
                                                    for a in sys.argv[1:]), load)
        print(f"\n{store}: {got['regions']:,} regions, {got['cells']:,} cells, "
              f"{got['pieces']:,} pieces, {got['edges']:,} edges in G; {got['surviving']:,} "
              f"cells survive ({got['eliminated']:,} eliminated): {got['verdict']}")
        print(f"{'step':<16} {'s':>8} {'peak MB':>9} {'sampled':>9}")
        for r in got["rows"]:
            peak = "-" if r["MB"] is None else f"{r['MB']:.0f}"
            print(f"{r['step']:<16} {r['s']:8.2f} {peak:>9} {r['sampled']:9.0f}")
        total = sum(r["s"] for r in got["rows"] if r["step"] != "imports")
        top = max((r["MB"] or 0) for r in got["rows"])
        print(f"{'total':<16} {total:8.2f} {top:9.0f}")
        print(f"load average {os.getloadavg()[0]:.1f} after", flush=True)


BEGIN, END = "<!-- bench_analyze_store: begin -->", "<!-- bench_analyze_store: end -->"


def write_doc(path: Path, got: dict, argv: str, load: float) -> None:
    """The store's steps as a Markdown table between :data:`BEGIN` and :data:`END` in
    ``path`` (the lines between replaced), with the counts and the command line."""
    text = path.read_text()
    if BEGIN not in text or END not in text:
        raise SystemExit(f"{path} has no {BEGIN} ... {END} lines")
    rows = ["", f"{got['regions']:,} regions, {got['cells']:,} cells, {got['pieces']:,} "
            f"pieces, {got['edges']:,} edges in G, verdict {got['verdict']} "
            f"(`bench_analyze_store.py {argv}`, load average {load:.1f}):", "",
            "| step | s | peak MB |", "| --- | --- | --- |"]
    for r in got["rows"]:
        if r["step"] != "imports":
            peak = "-" if r["MB"] is None else f"{r['MB']:,.0f}"
            rows.append(f"| {r['step']} | {r['s']:.1f} | {peak} |")
    rows.append("")
    head, rest = text.split(BEGIN, 1)
    tail = rest.split(END, 1)[1]
    path.write_text(head + BEGIN + "\n".join(rows) + "\n" + END + tail)


if __name__ == "__main__":
    main()
