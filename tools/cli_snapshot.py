"""Run every CLI command on the bundled examples and record what a user sees.

Run: ``python tools/cli_snapshot.py OUT.json [--src DIR]`` then
``python tools/cli_snapshot.py --compare A.json B.json``. For each command line below it records
the exit status, stdout, stderr and a hash of every text file the command wrote (maps written
by ``convert``, kernels, traces). ``--src`` runs another checkout's ``src`` (the code before a
change), so a refactoring can be shown to change no byte of output. Images are not compared
(matplotlib embeds no stable bytes); their existence is. Wall-clock
``"seconds"`` fields are masked.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EX = "src/tether/examples"

COMMANDS = [
    f"info {EX}/gallery.json",
    f"info {EX}/gallery.json --json",
    f"info {EX}/office.yaml --json",
    f"arcs {EX}/gallery.json --lss 2 --at 9 1.5",
    f"arcs {EX}/gallery.json --lss 2 --at 9 1.5 --json",
    f"decompose {EX}/gallery.wkt --lss 2",
    f"decompose {EX}/gallery.wkt --lss 2 --json",
    f"decompose {EX}/rectangle.json --lss 1 --json",
    f"decompose {EX}/convex_corner.geojson --lss 1 --json",
    f"decompose {EX}/nonconvex_corner.json --lss 1 --json",
    f"analyze {EX}/rectangle.json --lss 1",
    f"analyze {EX}/rectangle.json --lss 1 --json",
    f"analyze {EX}/gallery.json --lss 2 --json",
    f"analyze {EX}/convex_corner.json --lss 1 --json",
    f"analyze {EX}/nonconvex_corner.json --lss 1 --json",
    f"analyze {EX}/office.yaml --lss 1 --json",
    f"check {EX}/gallery.geojson --lss 2 --samples 50 --seed 7",
    f"check {EX}/gallery.geojson --lss 2 --samples 50 --seed 7 --json",
    f"check {EX}/rectangle.json --lss 1 --samples 30 --seed 1 --lines 4 --json",
    "bound --vt 1 --vo 2 --lss 1 --from 0 --to 1.5708",
    "bound --vt 1 --vo 2 --lss 1 --from 0 --to 1.5708 --json",
    f"assess {EX}/gallery.json --lss 2 --vt 0.3 --vo 1 --at 2 2.5 0.5",
    f"assess {EX}/gallery.json --lss 2 --vt 0.3 --vo 1 --at 2 2.5 0.5 --json",
    f"simulate {EX}/gallery.json --lss 2 --vt 0.3 --vo 1 --start 2 2.5 0.5 --target random "
    "--duration 5 --json",
    f"simulate {EX}/gallery.json --lss 2 --vt 0.3 --vo 1 --start 2 2.5 0.5 --target random "
    "--duration 5 --trace {OUT}/trace.json",
    f"convert {EX}/office.yaml {{OUT}}/office.geojson",
    f"convert {EX}/gallery.json {{OUT}}/gallery.wkt",
    f"convert {EX}/gallery.wkt {{OUT}}/gallery.json",
    f"sweep {EX}/rectangle.json --lss 0.5:2:0.25",
    f"sweep {EX}/rectangle.json --lss 0.5:2:0.25 --json",
    f"kernel {EX}/gallery.json --lss 2 --vt 0.3 --vo 1 --at 2 2.5 0.5 --json",
    "demo --out {OUT}/demo",
    # errors: one line, exit 2
    f"analyze {EX}/rectangle.json --lss -1",
    f"assess {EX}/gallery.json --lss 2 --vt 1 --vo 0.5 --at 2 2.5 0.5",
    f"arcs {EX}/gallery.json --lss 2 --at 100 100",
    "info no_such_map.json",
]


_SECONDS = re.compile(r'("seconds": )[0-9.e+-]+')


def _masked(text: str, tmp: str) -> str:
    """The output with the temporary folder and wall-clock times masked (they vary run to run)."""
    return _SECONDS.sub(r"\1<t>", text.replace(tmp, "{OUT}"))


def _files(out: Path) -> dict:
    rows = {}
    for p in sorted(out.rglob("*")):
        if not p.is_file():
            continue
        rel = str(p.relative_to(out))
        if p.suffix in (".png", ".gif", ".svg", ".pdf", ".mp4", ".npz"):
            rows[rel] = "<binary>"
        else:
            rows[rel] = hashlib.sha1(p.read_bytes()).hexdigest()[:16]
    return rows


def snapshot(src: str | None) -> dict:
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONHASHSEED="0")
    if src:
        env["PYTHONPATH"] = str(Path(src).resolve())
    rows = {}
    for line in COMMANDS:
        with tempfile.TemporaryDirectory() as tmp:
            args = line.replace("{OUT}", tmp).split()
            run = subprocess.run(
                [sys.executable, "-m", "tether.cli", *args],
                cwd=ROOT, env=env, capture_output=True, text=True,
            )
            rows[line] = {
                "rc": run.returncode,
                "stdout": _masked(run.stdout, tmp),
                "stderr": _masked(run.stderr, tmp),
                "files": _files(Path(tmp)),
            }
        print(f"{run.returncode}  {line}", file=sys.stderr)
    return rows


def compare(a: dict, b: dict) -> int:
    bad = [k for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)]
    for k in bad:
        print(f"DIFFERS: {k}")
        for part in ("rc", "stdout", "stderr", "files"):
            if a.get(k, {}).get(part) != b.get(k, {}).get(part):
                print(f"  {part}:\n    A: {str(a.get(k, {}).get(part))[:400]!r}"
                      f"\n    B: {str(b.get(k, {}).get(part))[:400]!r}")
    print(f"{len(set(a) | set(b))} command lines, {len(bad)} differ")
    return 1 if bad else 0


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out", nargs="?")
    ap.add_argument("--src", help="run another checkout's src directory")
    ap.add_argument("--compare", nargs=2, metavar=("A", "B"))
    a = ap.parse_args()
    if a.compare:
        sys.exit(compare(*(json.loads(Path(p).read_text()) for p in a.compare)))
    Path(a.out).write_text(json.dumps(snapshot(a.src), indent=1, sort_keys=True))


if __name__ == "__main__":
    main()
