"""Fingerprints of decompositions and verdicts, to check that a speed change keeps the results.

Run: ``python tools/fingerprint.py OUT.json [--big] [--src DIR]`` then
``python tools/fingerprint.py --compare A.json B.json``. For every case (the test maps and
examples at three rod lengths, ``tests/data``, 40 seeded random maps, floor plans of 100
vertices, with ``--big`` also 200 and 400) it records the counts, and hashes of the regions
(cells, area, representative point), the pieces (regions, kind, features), the pieces'
crossing samples, G, the surviving set and the elimination order, with the verdict. ``--src``
runs another checkout's ``src`` (e.g. the code before a change).
"""

from __future__ import annotations

import argparse
import glob
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _h(x) -> str:
    return hashlib.sha1(json.dumps(x, sort_keys=True, default=str).encode()).hexdigest()[:12]


def _cases(big: bool):
    import numpy as np

    sys.path.insert(0, str(ROOT / "tests"))
    sys.path.insert(0, str(ROOT / "tools"))
    import conftest
    from invariance_sweep import random_map  # the same seeded random maps

    from tether.examples.floorplan import floor_plan
    from tether.io import from_dict, load_map

    for env in conftest.MAPS:
        for lss in (1.0, 2.5, 4.0):
            yield f"{env.name}@{lss}", env, lss
    for p in sorted(glob.glob(str(ROOT / "examples" / "*.json"))):
        for lss in (1.0, 2.0, 4.0):
            yield f"{Path(p).name}@{lss}", load_map(p), lss
    for p in sorted(glob.glob(str(ROOT / "tests" / "data" / "*.json"))):
        d = json.loads(Path(p).read_text())
        yield Path(p).name, from_dict(d["map"]), d["lss"]
    rng = np.random.default_rng(12345)
    for i in range(40):
        env = random_map(rng)
        lss = float(rng.uniform(1.0, 6.0))
        yield f"rand{i}@{lss:.3f}", env, lss
    for n in ((100, 200, 400) if big else (100,)):
        env = floor_plan(n, seed=0)
        yield f"plan{n}", env, (env.bounds[2] - env.bounds[0]) / 15


def fingerprints(big: bool) -> dict:
    try:
        from tether.analysis import analyze
    except ImportError:  # a tree before tether.analysis (issue 23)
        from tether.escape import analyze
    from tether.decomposition import decompose

    out = {}
    for name, env, lss in _cases(big):
        try:
            dec = decompose(env, lss)
            v = analyze(dec)
        except Exception as exc:  # a refusal is a result too
            out[name] = {"error": repr(exc)[:200]}
            continue
        g, el = v.graph, v.eliminated
        out[name] = {
            "counts": dec.counts,
            "regions": _h([(r.cells, round(r.area, 6), [round(x, 6) for x in r.point])
                           for r in dec.regions]),
            "pieces": _h([(p.regions, p.kind, p.features) for p in dec.pieces]),
            "samples": _h([(p.sample, p.normal, p.eps, p.verified) for p in dec.pieces]),
            "G": _h([g.edge_a.tolist(), g.edge_b.tolist(), g.edge_piece.tolist()]),
            "verdict": v.strategy_exists, "verified": v.verified,
            "surviving": _h(sorted(v.surviving)),
            "elim": _h([el.cell.tolist(), el.piece.tolist(), el.round.tolist()]),
            "witness": v.witness_region, "unresolved": dec.unresolved_pieces,
        }
        print(name, out[name]["counts"], out[name]["verdict"], flush=True)
    return out


def compare(a: dict, b: dict) -> int:
    """Print the cases whose fingerprints differ (field by field); return their number."""
    bad = 0
    for k in a:
        if a[k] != b.get(k):
            bad += 1
            diff = {f: (a[k].get(f), (b.get(k) or {}).get(f)) for f in a[k]
                    if a[k].get(f) != (b.get(k) or {}).get(f)}
            print(k, diff)
    print(f"{bad} of {len(a)} cases differ")
    return bad


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out", nargs="?")
    ap.add_argument("--big", action="store_true", help="also floor plans of 200 and 400")
    ap.add_argument("--src", help="run another checkout's src directory")
    ap.add_argument("--compare", nargs=2, metavar=("A", "B"))
    args = ap.parse_args()
    if args.compare:
        a, b = (json.loads(Path(p).read_text()) for p in args.compare)
        sys.exit(1 if compare(a, b) else 0)
    if args.src:  # rerun this script with the other src first on the path
        env = dict(os.environ, PYTHONPATH=str(Path(args.src).resolve()))
        cmd = [sys.executable, __file__, args.out] + (["--big"] if args.big else [])
        sys.exit(subprocess.run(cmd, env=env).returncode)
    Path(args.out).write_text(json.dumps(fingerprints(args.big), indent=1))


if __name__ == "__main__":
    main()
