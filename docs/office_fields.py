"""Certify the bundled office map with a rod short enough for its doors (issue #22;
``docs/certified.md``, "Big maps") and save the field for ``docs/evidence_runs.py
--field-file`` and ``docs/certified_table.py --field-file``.

The recipe of the gallery at 0.6 (``docs/gallery_fields.py``, whose ``search`` and ``repair``
are used here): the search of :func:`~tether.game.certified.certified_kernel` with one core
size (``--core``, units of :func:`~tether.game.field_lp.vortex_radius`) on the mesh of
spacing ``--h``, then rounds of :func:`~tether.game.refine.refine_certified` with a local
search (``search_ring=2``) until the field is certified (at most ``--rounds``, default 0). With
``--fine H``, the certified field is then read on the uniform mesh of spacing ``H``
(:func:`~tether.game.certificate.interpolate_field`) and repaired there in patches
(:func:`~tether.game.patches.repair_patches`); ``--patches`` repairs the search's field in
patches on its own mesh first (the table of ``docs/certified.md``, "Big maps"). Whatever
is printed as certified was passed by :func:`~tether.game.certificate.certify`; the
file is certified again when read (:func:`~tether.game.certified.load_certified`). Every
step is deterministic (HiGHS, fixed orders), so the same command writes the same field bit
for bit (the log's timings aside).

Usage::

    python docs/office_fields.py --lss 0.24 --h 0.1 --fine 0.05 \\
        --save docs/evidence/fields/file_office_0.3_0.05_0.24.npz
    python docs/office_fields.py --lss 0.25 --h 0.1 --patches      # a row of the table
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from fractions import Fraction
from pathlib import Path

from tether.examples import load
from tether.game.certificate import free_mesh, interpolate_field
from tether.game.certified import CertifiedKernel
from tether.game.patches import lattice_points, repair_patches

sys.path.insert(0, str(Path(__file__).resolve().parent))
from gallery_fields import repair, search  # noqa: E402


def patch(ck: CertifiedKernel) -> CertifiedKernel:
    """``ck``'s field repaired in patches on its own mesh
    (:func:`~tether.game.patches.repair_patches`, at most 6 passes)."""
    s = ck.frame.scale
    f, checks, log = repair_patches(ck.space, ck.field, ck.lss * s, ck.vt / ck.vo, 1.0,
                                    passes=6)
    return replace(ck, field=f, checks=checks, log=[*ck.log, *log])


def report(what: str, ck: CertifiedKernel) -> None:
    """Print ``ck``'s failing triangles per check and where the *open* ones are (map units,
    the centroids, rounded to 0.1 m)."""
    f, c = ck.field, ck.checks
    cen = ck.frame.to_user(f.points[f.tri[c.open]].mean(axis=1))
    where = sorted({(round(x, 1), round(y, 1)) for x, y in cen})
    print(f"{what}: {len(f.points)} vertices, failing {c.counts()}, open at {where}",
          flush=True)


def to_fine(ck: CertifiedKernel, h: float, seconds: float | None) -> CertifiedKernel:
    """``ck``'s field read on the uniform mesh of spacing ``h`` (map units) and repaired
    there in patches (at most ``seconds`` of patches); its ``certify`` is the result's."""
    s = ck.frame.scale
    pts, tri, _ = free_mesh(ck.space, h * s, lattice_points(ck.space, h * s))
    f0 = interpolate_field(ck.field, pts, tri)
    f, checks, log = repair_patches(ck.space, f0, ck.lss * s, ck.vt / ck.vo, 1.0,
                                    seconds=seconds,
                                    progress=lambda r: print(f"patches {r}", flush=True))
    return replace(ck, h=h, field=f, checks=checks, log=[*ck.log, *log], refined=0,
                   refine_log=[])


#: The options: (name, type, default, help); the rest are flags.
OPTIONS = (("--lss", float, 0.24, "rod length (m)"), ("--ratio", float, 0.3, "vt/vo (vo = 1)"),
           ("--h", float, 0.1, "mesh spacing of the search (m)"),
           ("--core", str, "2/3", "core size in units of vortex_radius, a fraction (2/3)"),
           ("--rounds", int, 0, "local refinement rounds at most"),
           ("--fine", float, None, "then read the field at this spacing (m)"),
           ("--seconds", float, None, "patch budget at --fine (s)"),
           ("--save", str, None, "write the field here (CertifiedKernel.save)"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for name, kind, default, text in OPTIONS:
        ap.add_argument(name, type=kind, default=default, help=text)
    ap.add_argument("--patches", action="store_true",
                    help="repair the search's field in patches on its own mesh first")
    args = ap.parse_args()
    c0, w0 = time.process_time(), time.perf_counter()
    env = load("office", ".yaml")
    ck = search(env, args.lss, args.ratio, 1.0, args.h, float(Fraction(args.core)))
    if ck.checks is None:
        raise SystemExit(f"no first field: {ck.log[-1]}")
    report(f"search ({time.process_time() - c0:.0f} CPU s)", ck)
    if args.patches and not ck.certified:
        ck = patch(ck)
        report("patches", ck)
    ck = repair(ck, args.rounds)
    if args.fine is not None and ck.certified:
        ck = to_fine(ck, args.fine, args.seconds)
        print(f"fine {args.fine}: {len(ck.field.points)} vertices, failing "
              f"{ck.checks.counts()}", flush=True)
    summary(ck, time.process_time() - c0, time.perf_counter() - w0)
    if args.save:
        ck.save(args.save)


def summary(ck: CertifiedKernel, cpu: float, wall: float) -> None:
    """Print whether ``ck`` is certified, its size, the seconds spent and, if certified,
    its share of the free states (20,000 samples)."""
    share = ""
    if ck.certified:
        frac, err = ck.safe_fraction(20_000)
        share = f"; {100 * frac:.1f} ± {100 * err:.1f} % of the free states"
    print(f"certified {ck.certified}: {len(ck.field.points)} vertices, {cpu:.0f} CPU s, "
          f"{wall:.0f} s wall{share}")


if __name__ == "__main__":
    main()
