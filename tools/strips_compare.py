"""Compare a floor plan's decomposition with the noding in two strips against the whole noding.

Run: ``python tools/strips_compare.py [--sizes 400 1000]``. For each size it decomposes the
seeded floor plan twice (``tether.decomposition.noding.STRIP_MIN_SEGMENTS`` as is, and raised so
the input is noded whole), matches every region of the whole by its representative point, and
prints: the counts and verdicts, regions renumbered, structure mismatches, regions whose area
differs by more than 1e-9 relative (faces at the resolution limit joining another neighbour),
and whether the pieces and the eliminations are equal up to the renumbering."""

from __future__ import annotations

import argparse
import collections

import numpy as np

import tether.decomposition.noding as noding
from tether.analysis import analyze
from tether.decomposition import decompose
from tether.examples.floorplan import floor_plan


def compare(n: int) -> dict:
    env = floor_plan(n, seed=0)
    lss = (env.bounds[2] - env.bounds[0]) / 15
    limit = noding.STRIP_MIN_SEGMENTS
    got = {}
    try:
        for mode, lim in (("split", limit), ("whole", 10**15)):
            noding.STRIP_MIN_SEGMENTS = lim
            dec = decompose(env, lss)
            got[mode] = (dec, analyze(dec))
    finally:
        noding.STRIP_MIN_SEGMENTS = limit
    (a, va), (b, vb) = got["whole"], got["split"]
    j = b.region_at(np.array([r.point for r in a.regions]))  # whole region -> split region
    area_a = np.array([r.area for r in a.regions])
    area_b = np.array([b.regions[k].area for k in j])
    inv = np.empty_like(j)
    inv[j] = np.arange(len(j))

    def pieces(dec, ren):
        return collections.Counter((tuple(sorted(int(ren[r]) for r in p.regions)), p.kind,
                                    p.features) for p in dec.pieces)

    def elims(dec, v, ren):
        c = dec.cells
        return sorted((int(ren[c[i].region]), c[i].start_feature, c[i].end_feature, r)
                      for i, r in zip(v.eliminated.cell.tolist(), v.eliminated.round.tolist(),
                                      strict=True))

    ident = np.arange(len(j))
    return {
        "vertices": n, "same counts": a.counts == b.counts,
        "same verdict": va.strategy_exists == vb.strategy_exists and vb.verified,
        "renumbered": int(np.sum(j != ident)),
        "structure mismatches": sum(r.structure != b.regions[k].structure
                                    for r, k in zip(a.regions, j.tolist(), strict=True)),
        "areas off >1e-9": int(np.sum(np.abs(area_b - area_a) > 1e-9 * area_a)),
        "pieces equal": pieces(a, ident) == pieces(b, inv),
        "eliminations equal": elims(a, va, ident) == elims(b, vb, inv),
    }


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[400, 1000])
    for n in ap.parse_args().sizes:
        print(compare(n), flush=True)


if __name__ == "__main__":
    main()
