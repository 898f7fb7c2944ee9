"""Runs of the certified controller from certified starts, many and resumable: the evidence
of issue #22 ("from ≥ 10,000 simulations started in the certified kernel ... 0 lost").

For each field ``MAP:RATIO:H`` (bundled map, ``vt/vo``, mesh spacing; ``lss = vo = 1``) the
certified kernel is computed once and saved under ``DIR/fields/`` (a saved field is certified
again when read). A fourth part gives ``lss`` (``MAP:RATIO:H:LSS``); ``MAP`` may be a floor
plan, ``floor_plan:N:SEED`` (:func:`tether.examples.floorplan.floor_plan`); ``radial:`` in
front takes the radial field of :func:`tether.game.radial.radial_field` instead of the
search's; ``--field-file PATH`` copies a saved certified field in as ``file:STEM`` (the rod
length and speeds are the field's own).

Run ``i`` of a field is fixed by ``(field, i)``: its target kind is ``KINDS[i % 7]``, its start
a random certified state drawn from a generator seeded by the field's name and ``i``, the
target's seed is ``i``; each run is 15 s at ``dt`` = 0.02 s with the simulator's monitor on, in
the scene ``tether simulate`` builds (the map's decomposition and verdict, for the ``dash`` and
``escape`` targets), so any run can be replayed with the command the summary prints for it.

Each finished run appends one JSON line to a shard file ``DIR/runs-*.jsonl`` (one writer,
flushed per line); a rerun skips the ``(field, i)`` pairs the shards already hold, so the work
can be stopped at any time (Ctrl-C) and resumed, and shards from several sessions accumulate.
A line cut short by a kill is skipped when read (its run is done again).

Usage::

    python docs/evidence_runs.py --runs 3500 --workers 2            # the three certified rows
    nice -n 19 python docs/evidence_runs.py --runs 3500 --hours 1   # stop after an hour
    python docs/evidence_runs.py --summary                          # the table only
    python docs/evidence_runs.py --replay gallery:0.3:0.25:17       # one run again
    python docs/evidence_runs.py --field floor_plan:20:0:0.3:0.1:0.2 --runs 700
    python docs/evidence_runs.py --field-file /path/office.npz --runs 700

The summary: per field and target kind, the runs, the lost runs, the sampled states outside
the field (margin below ``-1e-9`` rad), and the CPU seconds per run (runs per CPU-hour); every
lost run with its replay command.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import signal
import sys
import time
import zlib
from collections import defaultdict
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

import numpy as np

from tether.analysis import analyze
from tether.decomposition import decompose
from tether.errors import TetherError
from tether.examples import path as example_path
from tether.examples.floorplan import floor_plan
from tether.game.certified import certified_kernel, load_certified
from tether.game.controller import CertifiedController, kernel_of
from tether.game.radial import radial_field
from tether.io import load_map
from tether.sim.paths import PathPlanner
from tether.sim.protocols import World
from tether.sim.simulate import check_start, simulate
from tether.strategies import TARGETS, make_target

DOCS = Path(__file__).resolve().parent
#: The certified rows of ``docs/certified.md``: map, vt/vo, mesh spacing (map units).
FIELDS = ("nonconvex_corner:0.3:0.25", "nonconvex_corner:0.6:0.25", "gallery:0.3:0.25",
          "radial:nonconvex_corner:0.9:0.075:0.15")
KINDS = tuple(sorted(set(TARGETS) - {"path", "track", "pedestrian"}))
LSS, VO, SECONDS, DT = 1.0, 1.0, 15.0, 0.02
#: A sampled state counts as outside the field below this margin (radians).
OUTSIDE = -1e-9
#: The markers of the table in the docs (``--doc``)
BEGIN, END = "<!-- evidence_runs: begin -->", "<!-- evidence_runs: end -->"


class Spec(NamedTuple):
    """A field's key parsed: ``[radial:]MAP:RATIO:H[:LSS]`` (``MAP`` a bundled map or
    ``floor_plan:N:SEED``), or ``file:STEM`` (a field file copied in with ``--field-file``)."""

    key: str
    name: str = ""
    ratio: float = 0.0
    h: float = 0.0
    lss: float = LSS
    radial: bool = False

    @property
    def external(self) -> bool:
        """Whether the field comes from a file only (it cannot be computed here)."""
        return self.key.startswith("file:")

    @property
    def bundled(self) -> bool:
        """Whether the map is a bundled example (``tether simulate`` can load it by path)."""
        return not self.external and not self.name.startswith("floor_plan:")

    def env(self):
        """The map."""
        if self.name.startswith("floor_plan:"):
            _, n, seed = self.name.split(":")
            return floor_plan(int(n), seed=int(seed))
        return load_map(example_path(self.name))


def parse_field(key: str) -> Spec:
    """``key`` as a :class:`Spec`; one line on a malformed key."""
    if key.startswith("file:"):
        if not key[5:] or "/" in key[5:]:
            raise SystemExit(f"evidence_runs: a file field is file:STEM, got {key!r}")
        return Spec(key)
    parts = key.split(":")
    radial = parts[0] == "radial"
    parts = parts[radial:]
    n_map = 3 if parts and parts[0] == "floor_plan" else 1
    name, rest = ":".join(parts[:n_map]), parts[n_map:]
    try:
        if len(rest) not in (2, 3) or not name:
            raise ValueError
        vals = [float(x) for x in rest]
        if n_map == 3:
            int(parts[1]), int(parts[2])
    except ValueError:
        raise SystemExit(f"evidence_runs: a field is MAP:RATIO:H or MAP:RATIO:H:LSS (MAP a "
                         f"bundled map or floor_plan:N:SEED, radial: in front for a radial "
                         f"field), got {key!r}") from None
    return Spec(key, name, vals[0], vals[1], vals[2] if len(vals) == 3 else LSS, radial)


def field_file(folder: Path, key: str) -> Path:
    """Where the field of ``key`` is saved."""
    return folder / "fields" / (key.replace(":", "_") + ".npz")


def compute_field(spec: Spec):
    """The field of ``spec``: the search of ``certified_kernel``, or the radial field of
    :func:`tether.game.radial.radial_field` (about the map's middle)."""
    if spec.external:
        raise SystemExit(f"evidence_runs: no field file for {spec.key}: add it with "
                         f"--field-file PATH")
    env = spec.env()
    if spec.radial:
        return radial_field(env, spec.lss, spec.ratio * VO, VO, spec.h)
    return certified_kernel(env, spec.lss, spec.ratio * VO, VO, h=spec.h)


def add_field_file(folder: Path, source: Path) -> str:
    """Copy a saved field (``CertifiedKernel.save``) into ``folder``'s fields as
    ``file:STEM`` after checking it (it must be certified); returns the key."""
    import shutil

    ck = load_certified(source)
    key = f"file:{source.stem}"
    if not ck.certified:
        raise SystemExit(f"evidence_runs: the field {source} is not certified: not added")
    dest = field_file(folder, key)
    dest.parent.mkdir(parents=True, exist_ok=True)
    if not dest.is_file():
        shutil.copyfile(source, dest)
    return key


def ensure_field(folder: Path, key: str):
    """The certified field of ``key``: computed and saved (atomically) if missing, then read
    back (and so certified again) so the runs use the very numbers a replay reads."""
    from tether._util.files import atomic_output

    path = field_file(folder, key)
    if not path.is_file():
        t0 = time.perf_counter()
        ck = compute_field(parse_field(key))
        print(f"{key}: field computed in {time.perf_counter() - t0:.0f} s, certified "
              f"{ck.certified}", file=sys.stderr, flush=True)
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_output(path) as tmp:
            ck.save(tmp)
    ck = load_certified(path)
    if not ck.certified:
        raise SystemExit(f"evidence_runs: the field {key} is not certified: no runs from it")
    return ck


class Scene:
    """What every run of one field shares (built once per process): the map, its field, the
    decomposition and verdict ``tether simulate`` computes, the coarse grid kernel the
    ``kernel-evader`` target computes on demand, and the path planner (stateless). The rod
    length and speeds are the field's own."""

    def __init__(self, folder: Path, key: str) -> None:
        self.key = key
        self.ck = ensure_field(folder, key)
        self.env = self.ck.env
        self.lss, self.vt, self.vo = self.ck.lss, self.ck.vt, self.ck.vo
        self.dec = decompose(self.env, self.lss)
        self.verdict = analyze(self.dec, near_critical=False)
        self.kernel = kernel_of(self.world())  # what the target computes when it is missing
        self.planner = PathPlanner(self.env)  # what the targets build (no clearance given)

    def world(self) -> World:
        """A fresh world for one run (its ``extra`` holds what the run may store)."""
        extra = {"certified": self.ck}
        if hasattr(self, "kernel"):
            extra.update(kernel=self.kernel, _planner=self.planner)
        return World(self.env, self.lss, self.vt, self.vo, self.dec, self.verdict, extra)

    def start(self, i: int) -> tuple[float, float, float]:
        """The certified start of run ``i``: a uniform point of the mesh and a uniform place
        in its arc, drawn until the simulator accepts it as a start."""
        rng = np.random.default_rng([zlib.crc32(self.key.encode()), i])
        x0, y0, x1, y1 = self.env.bounds
        world = World(self.env, self.lss, self.vt, self.vo)
        while True:
            pts = rng.uniform([x0, y0], [x1, y1], size=(64, 2))
            lo, hi, ok = self.ck.arcs(pts)
            a = lo + rng.uniform(0.0, 1.0, len(pts)) * (hi - lo)
            for k in np.flatnonzero(ok):
                s = (float(pts[k, 0]), float(pts[k, 1]), float(np.mod(a[k], math.tau)))
                if not self.ck.contains([s[:2]], s[2])[0]:
                    continue
                try:
                    check_start(world, *s)
                except TetherError:  # a start the simulator refuses: draw again
                    continue
                return s

    def run(self, i: int) -> dict:
        """Run ``i`` of this field as a JSON-ready record."""
        kind = KINDS[i % len(KINDS)]
        start = self.start(i)
        world = self.world()
        c0, w0 = time.process_time(), time.perf_counter()
        res = simulate(world, CertifiedController(), make_target(kind, world), start,
                       duration=SECONDS, dt=DT, seed=i)
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
        margin = self.ck.margin(res.trace.p, res.trace.a)
        return {"field": self.key, "i": i, "kind": kind, "start": list(start), "seed": i,
                "outcome": "held" if res.held else "lost", "lost_at": res.lost_at,
                "reason": res.reason,
                "outside": int((margin < OUTSIDE).sum()), "min_margin": float(margin.min()),
                "steps": len(res.trace) - 1, "max_speed_ratio": res.monitor.max_speed_ratio,
                "cpu_s": round(cpu, 4), "wall_s": round(wall, 4)}


_SCENES: dict[str, Scene] = {}  # per process: the fields' shared data (filled before forking)


def _work(task: tuple[str, int]) -> dict:
    key, i = task
    return _SCENES[key].run(i)


def read_shards(folder: Path) -> tuple[list[dict], int]:
    """The records of every shard in ``folder`` (the first of duplicates), and how many lines
    could not be read (cut short by a kill)."""
    seen, out, bad = set(), [], 0
    for shard in sorted(folder.glob("runs-*.jsonl")):
        for line in shard.read_text().splitlines():
            try:
                rec = json.loads(line)
                key = (rec["field"], rec["i"])
            except (json.JSONDecodeError, KeyError, TypeError):
                bad += 1
                continue
            if key not in seen:
                seen.add(key)
                out.append(rec)
    return out, bad


def tasks(fields: list[str], runs: int, done: set) -> list[tuple[str, int]]:
    """The runs ``0 .. runs-1`` of each field not yet done, interleaved across fields (so a
    stop leaves the fields about even)."""
    out = []
    for i in range(runs):
        out += [(key, i) for key in fields if (key, i) not in done]
    return out


def replay_command(rec: dict, folder: Path) -> str:
    """The commands that replay a record's run: this script's ``--replay``, and the
    ``tether simulate`` one where the CLI can build the same scene (a bundled map; it takes
    one ``--kernel``: for the ``kernel-evader`` target the field is computed again, which gives
    the same field only at the CLI's default spacing, 1/40 of the map's size, without
    ``radial:``)."""
    spec = parse_field(rec["field"])
    x, y, a = rec["start"]
    mine = f"python docs/evidence_runs.py --dir {folder} --replay {rec['field']}:{rec['i']}"
    if not spec.bundled:
        return mine
    if rec["kind"] == "kernel-evader":
        x0, y0, x1, y1 = load_map(example_path(spec.name)).bounds
        if spec.radial or spec.h != max(x1 - x0, y1 - y0) / 40:
            return mine
        field = ""
    else:
        field = f"--kernel {field_file(folder, rec['field'])} "
    return (f"{mine}\n  tether simulate {example_path(spec.name)} --lss {spec.lss:g} "
            f"--vt {spec.ratio * VO:g} --vo {VO:g} --controller certified {field}"
            f"--target {rec['kind']} --start {x!r} {y!r} {a!r} --seed {rec['seed']} "
            f"--duration {SECONDS:g} --dt {DT:g}")


def _label(key: str, folder: Path) -> tuple[str, str, str, str]:
    """A field's columns in the summary: map, vt/vo, lss, mesh h (for a file field, read from
    the file's parameters, its map named with the key's stem; the key alone if it is gone)."""
    spec = parse_field(key)
    if spec.external:
        path = field_file(folder, key)
        if not path.is_file():
            return (f"`{key}`", "", "", "")
        with np.load(path, allow_pickle=False) as d:
            lss, vt, vo, h = (float(x) for x in d["params"])
            name = json.loads(str(d["map"])).get("name", "")
        return (f"{name} (`{key}`)", f"{vt / vo:g}", f"{lss:g}", f"{h:g}")
    name = f"{spec.name} (radial)" if spec.radial else spec.name
    return (name, f"{spec.ratio:g}", f"{spec.lss:g}", f"{spec.h:g}")


def summary(records: list[dict], bad: int, folder: Path) -> str:
    """The markdown table of ``records`` (per field and kind, then totals) and the lost runs."""
    groups: dict[tuple[str, str], list[dict]] = defaultdict(list)
    for r in records:
        groups[(r["field"], r["kind"])].append(r)
    rows = ["| map | vt/vo | lss | mesh h | target | runs | lost | states outside | "
            "CPU s / run | runs / CPU-hour |",
            "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]

    def row(label: tuple[str, ...], rs: list[dict]) -> str:
        cpu = float(np.mean([r["cpu_s"] for r in rs]))
        lost = sum(r["outcome"] != "held" for r in rs)
        out = sum(r["outside"] for r in rs)
        return (f"| {' | '.join(label)} | {len(rs)} | {lost} | {out} | {cpu:.2f} | "
                f"{3600 / cpu:.0f} |")

    for (key, kind), rs in sorted(groups.items()):
        rows.append(row((*_label(key, folder), kind), rs))
    by_kind: dict[str, list[dict]] = defaultdict(list)
    for r in records:
        by_kind[r["kind"]].append(r)
    for kind, rs in sorted(by_kind.items()):
        rows.append(row(("all", "", "", "", kind), rs))
    if records:
        rows.append(row(("**all**", "", "", "", "**all**"), records))
    lost = [r for r in records if r["outcome"] != "held" or r["outside"]]
    text = "\n".join(rows) + f"\n\n{len(records)} runs, {len(lost)} lost or outside"
    text += f" ({bad} unreadable lines skipped)" if bad else ""
    for r in lost:
        text += (f"\n- {r['field']} run {r['i']} ({r['kind']}): {r['outcome']} at "
                 f"{r['lost_at']} s, {r['reason']}; {r['outside']} states outside\n  "
                 f"{replay_command(r, folder)}")
    return text


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dir", default=str(DOCS / "evidence"),
                    help="folder of the fields and the shards (default docs/evidence)")
    ap.add_argument("--field", action="append", metavar="KEY",
                    help="a field to run from, [radial:]MAP:RATIO:H[:LSS] or file:STEM; "
                    f"repeatable (default {' '.join(FIELDS)})")
    ap.add_argument("--field-file", action="append", metavar="PATH", default=[],
                    help="a saved certified field to copy in (as file:STEM) and run from")
    ap.add_argument("--runs", type=int, default=0,
                    help="runs per field in all, counting the shards' (default 0: none)")
    ap.add_argument("--workers", type=int, default=1, help="processes (forked; default 1)")
    ap.add_argument("--hours", type=float, default=math.inf,
                    help="stop starting runs after this many hours")
    ap.add_argument("--summary", action="store_true", help="print the table only")
    ap.add_argument("--doc", metavar="FILE",
                    help="also write the table into FILE between its evidence_runs markers")
    ap.add_argument("--replay", metavar="MAP:RATIO:H:I",
                    help="run run I of a field again and print its record")
    args = ap.parse_args()
    folder = Path(args.dir)
    if args.replay:
        key, _, i = args.replay.rpartition(":")
        print(json.dumps(Scene(folder, key).run(int(i))))
        return
    fields = [*(args.field or ([] if args.field_file else list(FIELDS))),
              *(add_field_file(folder, Path(f)) for f in args.field_file)]
    if not args.summary and args.runs > 0:
        folder.mkdir(parents=True, exist_ok=True)
        records, _ = read_shards(folder)
        todo = tasks(fields, args.runs, {(r["field"], r["i"]) for r in records})
        if todo:
            collect(folder, fields, todo, args.workers, args.hours)
    records, bad = read_shards(folder)
    chosen = args.field or args.field_file  # else every field the shards hold
    table = summary([r for r in records if not chosen or r["field"] in fields], bad, folder)
    print(table)
    if args.doc:
        write_doc(Path(args.doc), table)


def write_doc(doc: Path, table: str) -> None:
    """Replace the text between ``doc``'s evidence_runs markers by ``table`` (atomically)."""
    text = doc.read_text()
    if BEGIN not in text or END not in text:
        raise SystemExit(f"{doc}: no {BEGIN} ... {END} markers")
    head, rest = text.split(BEGIN, 1)
    tail = rest.split(END, 1)[1]
    tmp = doc.with_suffix(doc.suffix + ".tmp")
    tmp.write_text(f"{head}{BEGIN}\n{table.rstrip()}\n{END}{tail}")
    tmp.replace(doc)


@contextlib.contextmanager
def _results(todo: list[tuple[str, int]], workers: int) -> Iterator[Iterator[dict]]:
    """The records of ``todo``'s runs as they finish: in this process, or on ``workers``
    forked processes that ignore Ctrl-C (the parent stops them and keeps what was written;
    the runs under way are lost, and done again on resuming)."""
    if workers <= 1:
        yield map(_work, todo)
        return
    import multiprocessing

    ctx = multiprocessing.get_context("fork")
    with ctx.Pool(workers, initializer=signal.signal,
                  initargs=(signal.SIGINT, signal.SIG_IGN)) as pool:
        try:
            yield pool.imap_unordered(_work, todo)
        finally:
            pool.terminate()


def collect(folder: Path, fields: list[str], todo: list[tuple[str, int]], workers: int,
            hours: float) -> None:
    """Run ``todo`` on ``workers`` processes, appending each record to a new shard."""
    for key in fields:
        _SCENES[key] = Scene(folder, key)
    shard = folder / f"runs-{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}.jsonl"
    deadline = time.monotonic() + 3600 * hours
    print(f"{len(todo)} runs to do, {workers} workers, into {shard}", file=sys.stderr,
          flush=True)
    t0, n = time.perf_counter(), 0
    with shard.open("a") as fh, _results(todo, workers) as results:
        try:
            for rec in results:
                fh.write(json.dumps(rec) + "\n")
                fh.flush()
                n += 1
                _progress(n, len(todo), t0)
                if time.monotonic() > deadline:
                    break
        except KeyboardInterrupt:
            pass
    print(f"\n{n} runs written to {shard}", file=sys.stderr, flush=True)


def _progress(n: int, total: int, t0: float) -> None:
    if n % 10 == 0 or n == total:
        rate = n / max(time.perf_counter() - t0, 1e-9) * 3600
        print(f"\r{n}/{total} runs ({rate:.0f} runs/hour)", end="", file=sys.stderr,
              flush=True)


if __name__ == "__main__":
    main()
