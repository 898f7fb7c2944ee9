"""Regenerate the undecided-band table of ``docs/certified.md`` (between its ``band_table``
markers): per bundled map, speed ratio and mesh spacing ``h``, whether the certified kernel
exists, and how the free states of the optimistic grid kernel's lattice (spacing ``h``, 180
orientations) split into certified, undecided and unsafe, with the band's reach
(:func:`tether.game.band.undecided_band`).

Usage::

    python docs/band_table.py            # rewrites the table
    python docs/band_table.py --quick    # the room at 0.3 only, prints only

Takes about five minutes on the shared 2-core machine.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from doc_tables import write_between  # docs/, next to this script

from tether.examples import path as example_path
from tether.game import surveillance_kernel
from tether.game.band import undecided_band
from tether.game.certified import certified_kernel
from tether.io import load_map

DOCS = Path(__file__).resolve().parent
#: (map, vt/vo, mesh spacings in map units), coarse to fine.
ROWS = (("nonconvex_corner", 0.3, (0.5, 0.35, 0.25)),
        ("nonconvex_corner", 0.6, (0.5, 0.35, 0.25)),
        ("gallery", 0.3, (0.4, 0.25)))
LSS, VO = 1.0, 1.0
BEGIN, END = "<!-- band_table: begin -->", "<!-- band_table: end -->"


def row(name: str, ratio: float, h: float) -> str:
    """One markdown row: the certified kernel at ``h`` and its band against the optimistic
    kernel on the same lattice."""
    env = load_map(example_path(name))
    t0 = time.perf_counter()
    ck = certified_kernel(env, LSS, ratio * VO, VO, h=h)
    secs = time.perf_counter() - t0
    outer = surveillance_kernel(env, LSS, ratio * VO, VO, h=h, scheme="outer")
    b = undecided_band(ck, outer)
    pct = 100 / max(b.free_states, 1)
    yes = "yes" if ck.certified else "no"
    return (f"| {name} | {ratio:g} | {h:g} | {yes} | {b.free_states:,} | "
            f"{pct * b.certified_states:.1f} | {pct * b.undecided_states:.1f} | "
            f"{pct * b.unsafe_states:.1f} | {b.reach:.2f} | {b.reach_95:.2f} | "
            f"{b.contradictions} | {secs:.0f} |")


def table(rows) -> str:
    """The markdown table of ``rows`` ((map, ratio, spacings) triples)."""
    out = ["| map | vt/vo | h | certified | free lattice states | certified % | undecided % | "
           "unsafe % | reach | reach (95 %) | contradictions | seconds |",
           "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for name, ratio, spacings in rows:
        for h in spacings:
            out.append(row(name, ratio, h))
            print(out[-1], flush=True)
    return "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="the room at 0.3 only, print only")
    args = ap.parse_args()
    if args.quick:
        table(ROWS[:1])
        return
    body = table(ROWS)
    write_between(DOCS / "certified.md", BEGIN, END, body)


if __name__ == "__main__":
    main()
