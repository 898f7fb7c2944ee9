"""The certified surveillance kernel: a field of orientation arcs the exact checks pass
(:mod:`tether.game.certificate`), found by sequential LP (:mod:`tether.game.field_lp`) from the
conservative grid kernel, and the answer a user reads: from a state in it, no target of speed
at most ``vt`` breaks the line of sight (``docs/certified.md``).

A state outside the certified kernel is not thereby unsafe: :func:`classify` calls it
*undecided* where the optimistic grid kernel (scheme ``"outer"``) holds it, *unsafe* where
that kernel does not (the optimistic game's verdict, not a proof).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import shapely

from tether.arcs import rod_is_free_many
from tether.bounds import check_speeds
from tether.environment import Environment
from tether.environment.frame import Frame, identity_frame
from tether.errors import InvalidParameterError
from tether.game.certificate import FULL, ArcField, Checks, lifted_ends
from tether.game.field_lp import solve_field

__all__ = ["CertifiedKernel", "certified_kernel", "check_delay", "classify", "load_certified"]

_TAU = math.tau


@dataclass(eq=False)
class CertifiedKernel:
    """Result of :func:`certified_kernel`.

    Attributes
    ----------
    env : Environment
    lss, vt, vo, h : float
        Rod length, speeds and mesh spacing (map units, map units per second).
    field : ArcField
        The arcs on the mesh.
    checks : Checks or None
        The exact checks' result (None: the search had no field to check).
    certified : bool
        Whether every check passes: only then does :meth:`contains` say True anywhere.
    log : list of dict
        The search's record, one entry per try.
    seconds : float
        Wall time of the computation.
    frame : Frame
        The similarity from the map to the frame the field lives in (``field.points`` are in
        it): :func:`certified_kernel` works in the map's normalized frame
        (:attr:`Environment.frame`, a power-of-two scale, so that a map moved or scaled by a
        power of two gets the same field), with time scaled so that ``vo`` = 1.
    space : Environment, optional
        The map in that frame (default: ``env`` itself, for the identity frame).
    delay : float
        Sensing delay ``d`` (seconds) the field is certified for: the observer sees the
        target's position ``d`` seconds late, the field holds the *seen* state, and the line
        of sight from the observer to the true target is free (``docs/certified.md``,
        "Sensing delay"); the distance observer–target is then within ``lss ± vt·d``.
    refined : int
        Rounds of adaptive refinement that split the mesh
        (:func:`tether.game.refine.refine_certified`; 0: the uniform mesh of spacing ``h``).
        The mesh is then finer than ``h`` where the band was; ``h`` stays the spacing it
        started from (and that of the optimistic kernel's lattice).
    refine_log : list of dict
        The refinement's record, one entry per round (empty without refinement).
    """

    env: Environment
    lss: float
    vt: float
    vo: float
    h: float
    field: ArcField
    checks: Checks | None
    log: list = field(default_factory=list)
    seconds: float = 0.0
    frame: Frame = field(default_factory=identity_frame)
    space: Environment | None = None
    delay: float = 0.0
    refined: int = 0
    refine_log: list = field(default_factory=list)

    @property
    def game(self) -> tuple[Environment, float, float, float]:
        """The map, rod length and speeds of the field's frame (``vo`` = 1 there, unless the
        frame is the identity)."""
        if self.space is None:
            return self.env, self.lss, self.vt, self.vo
        return self.space, self.lss * self.frame.scale, self.vt / self.vo, 1.0

    @property
    def grow(self) -> float:
        """``vt·delay`` in the field's frame (map units there): how far the true target may be
        from the seen one."""
        return self.vt * self.delay * self.frame.scale

    @property
    def certified(self) -> bool:
        """Whether the field passed every check."""
        return self.checks is not None and self.checks.passed

    @cached_property
    def _tree(self) -> shapely.STRtree:
        return shapely.STRtree(shapely.polygons(self.field.points[self.field.tri]))

    def locate(self, points: Any) -> np.ndarray:
        """The mesh triangle holding each point (map units; -1 outside the free space): the
        first of the triangles that intersect it (a point on an edge lies in both)."""
        pts = self.frame.to_internal(np.asarray(points, dtype=float).reshape(-1, 2))
        hit_pt, hit_tri = self._tree.query(shapely.points(pts), predicate="intersects")
        out = np.full(len(pts), -1, dtype=np.int64)
        order = np.argsort(hit_pt, kind="stable")[::-1]  # the first hit of each point wins
        out[hit_pt[order]] = hit_tri[order]
        return out

    def arcs(self, points: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The field's arc ``[lo, hi]`` at each point (radians, ``hi − lo = 2π`` for the whole
        circle), and whether the point lies in the mesh (NaN ends where it does not)."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        t = self.locate(pts)
        pts = self.frame.to_internal(pts)
        ok = t >= 0
        lo = np.full(len(pts), np.nan)
        hi = np.full(len(pts), np.nan)
        if ok.any():
            tk = t[ok]
            L, H, whole = (x[tk] for x in self.triangle_ends())
            lam = _barycentric(self.field.points[self.field.tri[tk]], pts[ok])
            lo[ok] = (lam * L).sum(axis=1)
            hi[ok] = np.minimum((lam * H).sum(axis=1), lo[ok] + _TAU)
            hi[np.flatnonzero(ok)[whole]] = lo[ok][whole] + _TAU
        return lo, hi, ok

    def triangle_ends(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every mesh triangle's arc ends lifted to one branch, ``lo`` and ``hi`` (radians,
        (m, 3) each, :func:`~tether.game.certificate.lifted_ends`), and whether its three arcs
        are whole circles (m,): computed once per field (again if ``field`` is replaced)."""
        cached = self.__dict__.get("_ends")
        if cached is None or cached[0] is not self.field:
            f = self.field
            L, H, _ = lifted_ends(f.lo, f.w, f.tri)
            cached = self.__dict__["_ends"] = (f, L, H, (f.w[f.tri] >= FULL).all(axis=1))
        return cached[1], cached[2], cached[3]

    def margin(self, points: Any, angles: Any) -> np.ndarray:
        """Signed distance (radians) from each orientation to the nearest end of the arc:
        positive inside, negative outside, ``π`` where the arc is the whole circle, ``-π``
        off the mesh or where the field is not certified."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        ang = np.broadcast_to(np.asarray(angles, dtype=float), (len(pts),))
        lo, hi, ok = self.arcs(pts)
        out = np.full(len(pts), -math.pi)
        if not self.certified:
            return out
        x = np.mod(ang[ok] - lo[ok], _TAU)  # from lo, counter-clockwise
        width = hi[ok] - lo[ok]
        inside = np.minimum(x, width - x)
        outside = -np.minimum(x - width, _TAU - x)
        m = np.where(x <= width, inside, outside)
        out[ok] = np.where(width >= FULL, math.pi, m)
        return out

    def contains(self, points: Any, angles: Any) -> np.ndarray:
        """Whether each state ``(x, y, a)`` (map units, radians) is certified safe."""
        return self.margin(points, angles) >= 0

    def safe_fraction(self, samples: int = 100_000, seed: int = 0) -> tuple[float, float]:
        """The share of free states (target in the free space, rod free) the certified kernel
        holds, by Monte Carlo over uniform ``(x, y, a)``: ``(fraction, standard error)``."""
        rng = np.random.default_rng(seed)
        x0, y0, x1, y1 = self.env.bounds
        pts = np.empty((0, 2))  # map units
        while len(pts) < samples:
            q = rng.uniform([x0, y0], [x1, y1], size=(2 * samples, 2))
            pts = np.concatenate([pts, q[self.env.contains(q[:, 0], q[:, 1])]])[:samples]
        ang = rng.uniform(0, _TAU, samples)
        free = rod_is_free_many(self.env, pts, ang, self.lss)
        n = int(free.sum())
        if n == 0:
            return 0.0, 0.0
        f = float(self.contains(pts[free], ang[free]).mean())
        return f, math.sqrt(f * (1 - f) / n)

    def to_dict(self) -> dict:
        """The parameters and counts as JSON-ready values (the ``tether kernel --certified``
        fields)."""
        f = self.field
        return {
            "map": self.env.name, "lss": self.lss, "vt": self.vt, "vo": self.vo,
            "scheme": "certified", "h": self.h,
            "mesh": {"vertices": int(len(f.points)), "triangles": int(len(f.tri))},
            "certified": self.certified,
            "failing_triangles": None if self.checks is None else self.checks.counts(),
            "whole_circle_vertices": int(f.full.sum()),
            "mean_arc_fraction": float(np.mean(f.w) / _TAU),
            "search": self.log,
            "seconds": self.seconds,
            **({"delay": self.delay} if self.delay > 0 else {}),
            **({"refined": self.refined, "refine": self.refine_log} if self.refine_log
               else {}),
        }

    def save(self, path: str | Path) -> None:
        """Write the field, its parameters and the map (as JSON text) to an ``.npz`` file
        (:func:`load_certified` reads it and runs the checks again)."""
        import json

        f = self.field
        extra = {"delay": np.array(self.delay)} if self.delay > 0 else {}
        if self.refined:  # the mesh is not uniform: its refinement edges are in tri's order
            extra["refined"] = np.array(self.refined)
            extra["refine_log"] = np.array(json.dumps(self.refine_log))
        np.savez_compressed(path, points=f.points, tri=f.tri, lo=f.lo, w=f.w, **extra,
                            params=np.array([self.lss, self.vt, self.vo, self.h]),
                            frame=np.array([*self.frame.origin, self.frame.scale,
                                            float(self.space is not None)]),
                            log=np.array(json.dumps(self.log)),
                            map=np.array(json.dumps(self.env.to_dict())))


def load_certified(path: str | Path) -> CertifiedKernel:
    """Read a field written by :meth:`CertifiedKernel.save` and certify it again (a file is
    never trusted: the checks run on what was read)."""
    import json

    from tether.game.certificate import certify
    from tether.io import from_dict

    t0 = time.perf_counter()
    with np.load(path, allow_pickle=False) as d:
        f = ArcField(d["points"], d["tri"], d["lo"], d["w"])
        lss, vt, vo, h = (float(x) for x in d["params"])
        ox, oy, scale, internal = (float(x) for x in d["frame"])
        log = json.loads(str(d["log"]))
        env = from_dict(json.loads(str(d["map"])))
        delay = float(d["delay"]) if "delay" in d.files else 0.0
        refined = int(d["refined"]) if "refined" in d.files else 0
        refine_log = json.loads(str(d["refine_log"])) if refined else []
    frame = Frame(np.array([ox, oy]), scale)
    if internal and not (np.array_equal(env.frame.origin, frame.origin)
                         and env.frame.scale == scale):
        raise ValueError("the field's frame is not the map's normalized frame")
    ck = CertifiedKernel(env, lss, vt, vo, h, f, None, log, 0.0, frame,
                         env.internal if internal else None, check_delay(delay, vt, lss),
                         refined, refine_log)
    ck.checks = certify(f, *ck.game, grow=ck.grow)
    ck.seconds = time.perf_counter() - t0
    return ck


def _barycentric(tri: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (m, 3) of points ``pts`` (m, 2) in triangles ``tri`` (m, 3, 2)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1, v2 = b - a, c - a, pts - a
    det = v0[:, 0] * v1[:, 1] - v0[:, 1] * v1[:, 0]
    l1 = (v2[:, 0] * v1[:, 1] - v2[:, 1] * v1[:, 0]) / det
    l2 = (v0[:, 0] * v2[:, 1] - v0[:, 1] * v2[:, 0]) / det
    return np.stack([1 - l1 - l2, l1, l2], axis=1)


def check_delay(delay: Any, vt: float, lss: float) -> float:
    """``delay`` (seconds) as a float, or :class:`~tether.errors.InvalidParameterError`
    unless it is finite, ``>= 0`` and ``vt·delay < lss`` (the true target must stay nearer
    to the seen one than the rod is long)."""
    try:
        d = float(delay)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"the delay must be a number of seconds, got {delay!r}"
                                    ) from None
    if not (math.isfinite(d) and d >= 0):
        raise InvalidParameterError(f"the delay must be a finite number >= 0 s, got {delay}")
    if vt * d >= lss:
        raise InvalidParameterError(f"the delay {d:g} s is too long: vt·delay = {vt * d:g} "
                                    f"must be below lss = {lss:g}")
    return d


def certified_kernel(env: Environment, lss: float, vt: float, vo: float,
                     h: float | None = None, orientations: int = 180,
                     progress: Any = None, delay: float = 0.0,
                     start: CertifiedKernel | None = None,
                     coarse_h: float | None = None,
                     repair_seconds: float | None = None) -> CertifiedKernel:
    """The certified surveillance kernel: an arc field the exact checks pass, or the best
    field found with ``certified`` False (then nothing is claimed safe).

    Parameters
    ----------
    env : Environment
    lss, vt, vo : float
        Rod length (map units) and speed bounds (map units per second), ``0 < vt < vo``.
    h : float, optional
        Mesh spacing, map units; default 1/40 of the larger side of the bounding box.
    orientations : int
        Orientation bins of the conservative grid kernel the search starts from.
    progress : callable, optional
        Gets each LP round's record (a dict).
    delay : float
        Sensing delay, seconds (``0 <= vt·delay < lss``): the observer sees the target
        ``delay`` seconds late (``docs/certified.md``, "Sensing delay"). 0: no delay, the
        same field bit for bit.
    start : CertifiedKernel, optional
        A field of the same map, speeds and spacing (one certified at a shorter delay) to try
        first: checked at ``delay`` and kept if it passes, else the search starts from it.
    coarse_h : float, optional
        For big maps: search the field on a mesh of this spacing (map units, coarser than
        ``h``) first, read it on the mesh of spacing ``h`` and repair it there in patches
        (:func:`~tether.game.patches.coarse_to_fine`; ``docs/certified.md``, "Big maps"). No
        grid kernel at ``h`` is computed then. None (the default): the search on the mesh of
        ``h`` from the grid kernel at ``h``, as before.
    repair_seconds : float, optional
        With ``coarse_h``: start no patch after this many seconds of repair.

    Examples
    --------
    >>> from tether import Environment
    >>> from tether.game.certified import certified_kernel
    >>> room = Environment([(0, 0), (10, 0), (10, 10), (0, 10)])
    >>> ck = certified_kernel(room, 1.0, vt=0.3, vo=1.0, h=0.5)  # doctest: +SKIP
    >>> ck.certified, bool(ck.contains([[5.0, 5.0]], 0.0)[0])  # doctest: +SKIP
    (True, True)
    """
    from tether.game.kernel import surveillance_kernel

    check_speeds(vt, vo, lss)
    delay = check_delay(delay, vt, lss)
    x0, y0, x1, y1 = env.bounds
    if h is None:
        h = max(x1 - x0, y1 - y0) / 40
    if not (math.isfinite(h) and h > 0):
        raise InvalidParameterError(f"the mesh spacing h must be a finite number > 0, got {h}")
    if coarse_h is not None:
        if not (math.isfinite(coarse_h) and coarse_h > h):
            raise InvalidParameterError(f"the coarse spacing must be a finite number > h = "
                                        f"{h:g}, got {coarse_h}")
        if start is not None:
            raise InvalidParameterError("a start field and a coarse spacing exclude each other")
    t0 = time.perf_counter()
    frame, space = env.frame, env.internal
    lss_i, vt_i, vo_i = lss * frame.scale, vt / vo, 1.0
    if coarse_h is not None:
        return _coarse_to_fine(env, lss, vt, vo, h, orientations, progress, delay, coarse_h, t0,
                               repair_seconds)
    kern = surveillance_kernel(space, lss_i, vt_i, vo_i, h=h * frame.scale,
                               orientations=orientations)
    try:
        f, checks, log = solve_field(space, kern, lss_i, vt_i, vo_i, progress=progress,
                                     grow=vt * delay * frame.scale,
                                     start=None if start is None else start.field)
    except ValueError as exc:  # the mesh cannot follow the walls at this spacing
        raise InvalidParameterError(f"no certified kernel at h = {h:g}: {exc}") from None
    return CertifiedKernel(env, lss, vt, vo, h, f, checks, log, time.perf_counter() - t0,
                           frame, space, delay)


def _coarse_to_fine(env: Environment, lss: float, vt: float, vo: float, h: float,
                    orientations: int, progress: Any, delay: float, coarse_h: float,
                    t0: float, seconds: float | None) -> CertifiedKernel:
    """:func:`certified_kernel` with ``coarse_h``: :func:`~tether.game.patches.coarse_to_fine`
    in the map's normalized frame."""
    from tether.game.patches import coarse_to_fine

    frame, space = env.frame, env.internal
    try:
        f, checks, log = coarse_to_fine(space, lss * frame.scale, vt / vo, 1.0,
                                        h * frame.scale, coarse_h * frame.scale,
                                        orientations, grow=vt * delay * frame.scale,
                                        seconds=seconds, progress=progress)
    except ValueError as exc:  # a mesh cannot follow the walls at this spacing
        raise InvalidParameterError(f"no certified kernel at h = {h:g} from {coarse_h:g}: "
                                    f"{exc}") from None
    return CertifiedKernel(env, lss, vt, vo, h, f, checks, log, time.perf_counter() - t0,
                           frame, space, delay)


def classify(certified: CertifiedKernel, optimistic: Any, points: Any,
             angles: Any) -> np.ndarray:
    """``"safe"`` where the certified kernel holds the state, ``"unsafe"`` where the
    optimistic grid kernel (``optimistic``: a :class:`~tether.game.kernel.Kernel` of scheme
    ``"outer"``) does not, ``"undecided"`` elsewhere (array of str)."""
    safe = certified.contains(points, angles)
    maybe = optimistic.contains(points, angles)
    return np.where(safe, "safe", np.where(maybe, "undecided", "unsafe"))
