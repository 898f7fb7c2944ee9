"""Verification tool: lattice maps (walls on a 0.05 grid, round lss) checked two ways.

Run: ``python tools/lattice_sweep.py [--seeds 60] [--lss 0.25 0.5] [--lines 12]``.

For each rasterized random shape of ``tests/lattice_maps.py`` (seeds ``0..N-1``, 40 x 40 cells
of 0.05) and each family of degenerate rooms there, at each lss:

* **exact**: the decomposition scanned along ``--lines`` random lines against the exact free
  arcs (:func:`tether.decomposition.scan.scan`); any disagreement is printed;
* **invariance**: the same map scaled by 0.1, 8 and 10, turned by 90 degrees, mirrored and moved
  to (4.5e5, 5.4e6): counts (curves, regions, cells, pieces), verdict and the number of
  surviving cells must equal the original's, and the verdict must be verified. ``far`` lies
  beyond the documented guarantee for maps a few metres across (1e5 diameters from the
  origin): its differences are listed apart.

Prints one line per case that fails and a summary table. Not a test: it takes minutes.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from lattice_maps import env_of, families, rasterized  # noqa: E402

from tether.analysis import analyze  # noqa: E402
from tether.decomposition import decompose  # noqa: E402
from tether.decomposition.scan import scan  # noqa: E402
from tether.errors import TetherError  # noqa: E402

TRANSFORMS = {"x0.1": (lambda x, y: (0.1 * x, 0.1 * y), 0.1),
              "x8": (lambda x, y: (8 * x, 8 * y), 8.0),
              "x10": (lambda x, y: (10 * x, 10 * y), 10.0),
              "rot90": (lambda x, y: (-y, x), 1.0),
              "mirror": (lambda x, y: (-x, y), 1.0),
              "far": (lambda x, y: (x + 4.5e5, y + 5.4e6), 1.0)}


def _moved(rings, f):
    return ([f(*p) for p in rings[0]], [[f(*p) for p in h] for h in rings[1]])


def _summary(v) -> tuple:
    return (v.dec.counts, v.strategy_exists, len(v.surviving))


def check_map(name: str, rings, lss: float, lines: int, tally: Counter) -> None:
    try:
        env = env_of(rings, name)
        dec = decompose(env, lss)
    except TetherError as exc:
        tally["refused"] += 1
        print(f"{name} lss {lss}: refused: {exc}", flush=True)
        return
    _, bad = scan(dec, lines)
    tally["exact"] += 1
    if bad:
        tally["exact failed"] += 1
        kinds = Counter(b["kind"] for b in bad)
        print(f"{name} lss {lss}: {len(bad)} line disagreements {dict(kinds)}: {bad[0]}",
              flush=True)
    base = analyze(dec, near_critical=False)
    for how, (f, k) in TRANSFORMS.items():
        v = analyze(decompose(env_of(_moved(rings, f), name), lss * k), near_critical=False)
        tally["moved"] += 1
        same = _summary(v) == _summary(base) and bool(v.verified)
        if not same:
            tally[f"moved differs{' (far)' if how == 'far' else ''}"] += 1
            print(f"{name} lss {lss} {how}: {_summary(base)} -> {_summary(v)}, verified "
                  f"{v.verified}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=60, help="rasterized shapes (default 60)")
    ap.add_argument("--lss", type=float, nargs="+", default=[0.25, 0.5])
    ap.add_argument("--lines", type=int, default=12, help="lines scanned per map")
    args = ap.parse_args()
    tally: Counter = Counter()
    for lss in args.lss:
        for name, rings in families(lss).items():
            check_map(name, rings, lss, args.lines, tally)
        for seed in range(args.seeds):
            rings = rasterized(seed, cells=40)
            if rings is not None:
                check_map(f"raster{seed}", rings, lss, args.lines, tally)
    print()
    for key in ("exact", "exact failed", "moved", "moved differs", "moved differs (far)",
                "refused"):
        print(f"{key:>22}  {tally[key]}")


if __name__ == "__main__":
    main()
