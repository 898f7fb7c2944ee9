"""Regenerate the side-by-side table of safe fractions in ``docs/certified.md`` (between its
``fractions_table`` markers): per bundled map and speed ratio (``lss`` = 1, ``vo`` = 1), the
share of free states (target in the free space, rod free) that each answer calls safe, all on
the **same** random states:

- the paper's Props. 2–3 with the safe trigger ``L_g`` (``tether.analysis.is_safe``; not
  sound, ``docs/strategy.md``);
- the certified kernel (``certified_kernel``, mesh ``h`` = 0.25; 0 where no field is
  certified): a proof;
- the conservative (``inner``) and optimistic (``outer``) grid kernels on the same lattice
  (180 orientations): neither is a proof.

Usage::

    python docs/fractions_table.py                 # every row, rewrites the table
    python docs/fractions_table.py --samples 2000 --print-only
    python docs/fractions_table.py --skip convex_corner:0.6   # a row left out
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np
from doc_tables import write_between  # docs/, next to this script

from tether.analysis import analyze
from tether.analysis import is_safe as paper_is_safe
from tether.arcs import rod_is_free_many
from tether.decomposition import decompose
from tether.examples import path as example_path
from tether.game import surveillance_kernel
from tether.game.certified import certified_kernel
from tether.io import load_map

DOCS = Path(__file__).resolve().parent
MAPS = ("nonconvex_corner", "convex_corner", "gallery")
RATIOS = (0.3, 0.6, 0.9)
LSS, VO, H = 1.0, 1.0, 0.25
BEGIN, END = "<!-- fractions_table: begin -->", "<!-- fractions_table: end -->"
HEADER = ("| map | vt/vo | paper's Props. 2–3 (L_g) % | certified % | inner kernel % | "
          "outer kernel % | certified within paper's | certified s |")
RULE = "| --- | --- | --- | --- | --- | --- | --- | --- |"


def free_states(env, n: int, rng) -> tuple[np.ndarray, np.ndarray]:
    """``n`` uniform states ``(x, y)``, ``a`` (map units, radians) with the target in the
    free space and the rod of length ``LSS`` free."""
    x0, y0, x1, y1 = env.bounds
    pts, ang = np.empty((0, 2)), np.empty(0)
    while len(pts) < n:
        q = rng.uniform([x0, y0], [x1, y1], size=(2 * n, 2))
        q = q[env.contains(q[:, 0], q[:, 1])]
        a = rng.uniform(0.0, math.tau, len(q))
        ok = rod_is_free_many(env, q, a, LSS)
        pts, ang = np.concatenate([pts, q[ok]]), np.concatenate([ang, a[ok]])
    return pts[:n], ang[:n]


def pct(mask: np.ndarray) -> str:
    """A share in percent with its Monte Carlo standard error."""
    f = float(np.mean(mask))
    return f"{100 * f:.1f} ± {100 * math.sqrt(f * (1 - f) / len(mask)):.1f}"


def rows(samples: int, skip: frozenset = frozenset()) -> list[str]:
    """The markdown rows, each printed as it is made (``skip``: ``(map, ratio)`` pairs whose
    certified kernel is not computed, each given a row that says so)."""
    out = [HEADER, RULE]
    print(HEADER, flush=True)
    for name in MAPS:
        env = load_map(example_path(name))
        ver = analyze(decompose(env, LSS))
        pts, ang = free_states(env, samples, np.random.default_rng(0))
        for ratio in RATIOS:
            vt = ratio * VO
            if (name, ratio) in skip:
                out.append(f"| {name} | {ratio:g} | not run (`--skip`) | | | | | |")
                continue
            paper = np.asarray(paper_is_safe(ver, vt, VO, pts, ang), dtype=bool)
            t0 = time.process_time()
            ck = certified_kernel(env, LSS, vt, VO, h=H)
            secs = time.process_time() - t0
            cert = ck.contains(pts, ang) if ck.certified else np.zeros(len(pts), bool)
            inner = surveillance_kernel(env, LSS, vt, VO, h=H).contains(pts, ang)
            outer = surveillance_kernel(env, LSS, vt, VO, h=H, scheme="outer").contains(pts,
                                                                                      ang)
            both = f"{int((cert & paper).sum())} of {int(cert.sum())}"
            out.append(f"| {name} | {ratio:g} | {pct(paper)} | {pct(cert)} | {pct(inner)} | "
                       f"{pct(outer)} | {both} | {secs:.0f} |")
            print(out[-1], flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=20_000, help="states per map")
    ap.add_argument("--print-only", action="store_true", help="do not rewrite the doc")
    ap.add_argument("--skip", action="append", default=[], metavar="MAP:RATIO",
                    help="leave this row out (its certified kernel is not computed)")
    args = ap.parse_args()
    skip = frozenset((m, float(r)) for m, r in (k.split(":") for k in args.skip))
    body = "\n".join(rows(args.samples, skip))
    if args.print_only:
        return
    write_between(DOCS / "certified.md", BEGIN, END, body)


if __name__ == "__main__":
    main()
