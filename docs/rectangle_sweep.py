"""Sweep the paper's Fig. 6 rectangle: width and height from 0.3 to 3.0 lss, step 0.1.

Run: ``python docs/rectangle_sweep.py`` (about a minute). Writes ``docs/rectangle_sweep.md``:
regions/cells of tether's decomposition for every proportion, the cells surviving the
elimination, and where the paper's counts (18 regions, 32 cells) are met. Every decomposition
is verified with ``tether.decomposition.check`` and marked ``!`` if it disagrees.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tether import Environment
from tether.decomposition import check, decompose

STEPS = np.round(np.arange(0.3, 3.0001, 0.1), 1)


def survivors(dec) -> int | None:
    try:
        from tether.analysis import analyze
    except ImportError:  # the elimination is a later stage
        return None
    return len(analyze(dec).surviving)


def main() -> None:
    rows, hits = [], []
    for w in STEPS:
        cells = []
        for h in STEPS:
            env = Environment([[0, 0], [w, 0], [w, h], [0, h]], (), f"rect {w}x{h}")
            dec = decompose(env, 1.0)
            ok = check(dec, 10).ok
            s = survivors(dec)
            text = f"{len(dec.regions)}/{len(dec.cells)}" + ("" if s is None else f"/{s}")
            cells.append(text + ("" if ok else "!"))
            if (len(dec.regions), len(dec.cells)) == (18, 32):
                hits.append((w, h))
        rows.append((w, cells))
        print(f"w={w}: done", flush=True)
    out = ["# The paper's rectangle (Fig. 6): counts against proportions", "",
           "Width `w` (rows) and height `h` (columns) in units of `lss`. Each entry is",
           "`regions/cells/surviving cells` of tether's decomposition (`!`: the self-check",
           "disagreed). Regenerate with `python docs/rectangle_sweep.py`.", "",
           "| w \\ h | " + " | ".join(f"{h:.1f}" for h in STEPS) + " |",
           "|---" * (len(STEPS) + 1) + "|"]
    for w, cells in rows:
        out.append(f"| **{w:.1f}** | " + " | ".join(cells) + " |")
    out += ["", "Proportions giving the paper's 18 regions and 32 cells: "
            + (", ".join(f"{w:.1f} x {h:.1f}" for w, h in hits) if hits else "none") + "."]
    Path(__file__).with_name("rectangle_sweep.md").write_text("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
