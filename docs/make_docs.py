"""Regenerate the console examples of the README and docs/ from the code.

A checked example is a marker line followed by a ``console`` code block::

    <!-- checked: tether info src/tether/examples/gallery.json -->
    ```console
    $ tether info src/tether/examples/gallery.json
    map 'gallery': 14 vertices, ...
    ```

``python docs/make_docs.py`` runs every marked command (in-process, from the repository root,
stdout then stderr, and ``[exit N]`` when the status is not 0) and rewrites the block below the
marker with ``$ command`` and the actual output. ``python docs/make_docs.py --check`` rewrites
nothing and exits 1 if any block is stale (``tests/test_docs.py`` runs this check).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import re
import shlex
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FILES = ["README.md", "docs/conventions.md", "docs/formulas.md", "docs/errata.md",
         "docs/paper_examples.md"]

MARKER = re.compile(
    r"^<!-- checked: (?P<cmd>tether [^\n]*?) -->\n"
    r"(?:```console\n(?P<body>.*?)^```\n)?",
    re.S | re.M,
)


def run_command(cmd: str) -> str:
    """Output of ``tether ...`` run in-process from the repository root, as a console block."""
    from tether.cli import main

    argv = shlex.split(cmd)[1:]
    out, err = io.StringIO(), io.StringIO()
    old = Path.cwd()
    os.chdir(ROOT)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            status = main(argv)
    finally:
        os.chdir(old)
    text = out.getvalue() + err.getvalue()
    if status:
        text += f"[exit {status}]\n"
    return f"$ {cmd}\n{text}"


def render(text: str) -> tuple[str, list[str]]:
    """``text`` with every checked block regenerated, and the commands whose block changed."""
    stale: list[str] = []

    def block(m: re.Match) -> str:
        body = run_command(m.group("cmd"))
        if body != (m.group("body") or ""):
            stale.append(m.group("cmd"))
        return f"<!-- checked: {m.group('cmd')} -->\n```console\n{body}```\n"

    return MARKER.sub(block, text), stale


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true",
                    help="rewrite nothing; exit 1 if a block is stale")
    ap.add_argument("files", nargs="*", default=FILES, help="files relative to the repository")
    args = ap.parse_args(argv)
    os.environ.setdefault("MPLBACKEND", "Agg")
    any_stale = False
    for name in args.files:
        path = ROOT / name
        if not path.exists():
            continue
        new, stale = render(path.read_text())
        for cmd in stale:
            print(f"{name}: stale output of `{cmd}`")
        if stale:
            any_stale = True
            if not args.check:
                path.write_text(new)
    if args.check and any_stale:
        print("run `python docs/make_docs.py` to regenerate them")
    return 1 if (args.check and any_stale) else 0


if __name__ == "__main__":
    sys.exit(main())
