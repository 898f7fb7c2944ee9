"""The discriminating kernel of the surveillance game on a grid (``docs/formulas.md``,
"The surveillance kernel").

``K_0`` is the set of free states of the :class:`~tether.game.grid.StateGrid`; a state ``(p, a)``
stays in ``K_{n+1}`` iff for every target move ``d`` (a lattice step to a neighbour ``p'``) some
admissible orientation ``a'`` has ``(p', a') ∈ K_n``. The iteration stops when nothing changes
(the greatest fixed point, a finite computation).

The discretization, and which way each choice errs
-------------------------------------------------
* **Time step tied to the grid.** The target moves one lattice step ``d`` (length ``|d|``, one
  cell or a diagonal) at speed ``vt`` in ``τ_d = |d|/vt``: its successor is exactly a grid
  point, so no position is ever rounded (the naive "every cell the successor may round to"
  rule erodes the kernel to nothing as iterations accumulate; it is not used). The target may
  change heading only every ``τ_d`` and only among 8 or 16 headings: **optimistic** for the
  observer, an error that vanishes as ``h → 0``.
* **The observer's rates.** For move ``d`` from bin ``a``, the reachable orientations are
  ``a + τ_d·Ω(v_d, a)`` (``Ω`` evaluated at the start of the move). Scheme ``"inner"`` (the
  default) admits the bins whose centre lies in that interval: every admitted bin is truly
  reachable, so the rounding is **conservative** (it errs by at most one bin, ``δ``).
  Scheme ``"outer"`` dilates the interval by ``e = δ/2 + τ_d²·vt·vo/lss²`` (half a bin, plus a
  bound on the change of ``Ω`` along the sweep) and admits every bin it touches:
  **optimistic**. The two bracket the continuous kernel up to the other errors; both errors
  vanish as ``h → 0`` and ``n_a → ∞`` at a fixed ratio ``h·n_a`` (refine the two together:
  with ``n_a`` fixed and ``h → 0`` the inner scheme degenerates, since ``τ·vo/lss`` falls below
  one bin; :attr:`Kernel.rate_bins` reports the number of bins a saturated rotation covers).
* **Free along the sweep.** The rod must stay free: the orientations it can be carried to at
  ``p'`` are those of the runs met by rotating within the exact free arc at ``p``, translating
  to the move's midpoint, rotating within the arc there, and translating on
  (:meth:`~tether.game.grid.StateGrid.continuations`); the rate bound then cuts that set to
  ``a + τ_d·Ω``. The arcs are exact at the three points; the half-step translations are not
  checked in between and split arcs are taken as their hull, which errs **optimistically**
  only within a cell of a critical curve. (Without the midpoint, an arc that turns by more
  than its width in one step, as when the target passes close to a reflex vertex, was cut
  for nothing: a spurious trap that emptied whole kernels.)

Implementation: "some bin of an interval is in ``K_n``" is a difference of prefix sums along
the orientation axis (three copies of the circle, so wrapped intervals are plain ranges); one
iteration is a handful of vectorized gathers per direction. A worklist of points keeps only the
predecessors of points whose kernel changed.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from tether.bounds import check_speeds
from tether.environment import Environment
from tether.errors import InvalidParameterError
from tether.game.grid import StateGrid, build_grid
from tether.rates import rate_interval

__all__ = ["IN_KERNEL", "Kernel", "SCHEMES", "load_kernel", "surveillance_kernel"]

SCHEMES = ("inner", "outer")
#: ``Kernel.level`` of the states that are never removed.
IN_KERNEL = np.iinfo(np.int32).max


@dataclass(frozen=True, eq=False)
class Kernel:
    """Result of :func:`surveillance_kernel`.

    ``kernel[i, k]`` says whether state (grid point ``i``, bin ``k``) is in the kernel;
    ``history`` is the number of kernel states after each iteration; ``level[i, k]`` the
    iteration that removed the state (0: not free, :data:`IN_KERNEL` for kernel states). From
    a state of level ``n`` the target has a move after which every observer answer has a
    level below ``n``: the discrete game's winning strategy, which :class:`KernelEvader`
    follows.

    Examples
    --------
    >>> from tether import Environment
    >>> from tether.game import surveillance_kernel
    >>> ell = Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])  # an L-shaped room
    >>> kern = surveillance_kernel(ell, 0.5, vt=0.3, vo=1.0, h=0.25, orientations=36)
    >>> kern.states, kern.free_states, kern.kernel_states
    (9216, 5436, 5416)
    """

    grid: StateGrid = field(repr=False)
    kernel: np.ndarray = field(repr=False)
    lss: float
    vt: float
    vo: float
    scheme: str
    directions: int
    iterations: int
    converged: bool
    seconds: float
    history: tuple[int, ...] = field(default=(), repr=False)
    level: np.ndarray | None = field(default=None, repr=False)

    # ----- counts -------------------------------------------------------------------------
    @property
    def states(self) -> int:
        """Number of states of the full lattice box (points × orientation bins)."""
        ny, nx, n_a = self.grid.shape
        return nx * ny * n_a

    @property
    def free_states(self) -> int:
        """Number of free states (rod free at the grid point and bin centre)."""
        return int(self.grid.free.sum())

    @property
    def kernel_states(self) -> int:
        """Number of states in the kernel."""
        return int(self.kernel.sum())

    @property
    def rate_bins(self) -> float:
        """Bins swept by a saturated rotation during one axis move: ``(h/vt)·(vo/lss)/δ``."""
        return self.grid.h / self.vt * self.vo / self.lss / self.grid.delta

    def to_dict(self) -> dict:
        """The parameters and counts as JSON-ready values (the ``tether kernel`` fields)."""
        return {
            "map": self.grid.env.name,
            "lss": self.lss, "vt": self.vt, "vo": self.vo,
            "scheme": self.scheme, "directions": self.directions,
            "grid": self.grid.to_dict(),
            "states": self.states,
            "free_states": self.free_states,
            "kernel_states": self.kernel_states,
            "safe_fraction": self.safe_fraction_total(),
            "no_safe_start_points": int(len(self.no_safe_start)),
            "iterations": self.iterations,
            "converged": self.converged,
            "seconds": self.seconds,
        }

    # ----- look-ups -----------------------------------------------------------------------
    def contains(self, points: Any, angles: Any) -> np.ndarray:
        """Whether each configuration ``(x, y, a)`` is in the kernel: nearest grid point and
        nearest orientation bin (False off the grid's points)."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        ang = np.broadcast_to(np.asarray(angles, dtype=float), (len(pts),))
        i = self.grid.point_at(pts)
        k = self.grid.bin_at(ang)
        out = np.zeros(len(pts), dtype=bool)
        ok = i >= 0
        out[ok] = self.kernel[i[ok], k[ok]]
        return out

    def level_at(self, points: Any, angles: Any) -> np.ndarray:
        """:attr:`level` of the nearest state (0 off the grid's points)."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        ang = np.broadcast_to(np.asarray(angles, dtype=float), (len(pts),))
        i = self.grid.point_at(pts)
        k = self.grid.bin_at(ang)
        out = np.zeros(len(pts), dtype=np.int64)
        ok = i >= 0
        lev = self.level if self.level is not None else np.where(self.kernel, IN_KERNEL, 0)
        out[ok] = lev[i[ok], k[ok]]
        return out

    def margin(self, points: Any, angles: Any) -> np.ndarray:
        """Signed distance in orientation (radians) from ``a`` to the kernel's boundary over
        the nearest grid point: positive inside (distance to the nearest bin outside the
        kernel, ``π`` when every bin is in), negative outside (minus the distance to the
        nearest kernel bin, ``-π`` when none is), measured between bin centres."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        ang = np.broadcast_to(np.asarray(angles, dtype=float), (len(pts),))
        i = self.grid.point_at(pts)
        rows = np.zeros((len(pts), self.grid.n_a), dtype=bool)
        ok = i >= 0
        rows[ok] = self.kernel[i[ok]]
        d = np.abs(np.mod(self.grid.angles[None, :] - ang[:, None] + math.pi, math.tau) - math.pi)
        inside = self.contains(pts, ang)
        far = np.where(rows, np.inf, d).min(axis=1)  # nearest bin outside
        near = np.where(rows, d, np.inf).min(axis=1)  # nearest bin inside
        return np.where(inside, np.minimum(far, math.pi), -np.minimum(near, math.pi))

    def safe_fraction(self) -> np.ndarray:
        """For each grid point, the fraction of its free orientations that are in the kernel
        (NaN where no orientation is free)."""
        nf = self.grid.free.sum(axis=1)
        nk = self.kernel.sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(nf > 0, nk / np.maximum(nf, 1), np.nan)

    def safe_fraction_total(self) -> float:
        """Fraction of all free states that are in the kernel."""
        return self.kernel_states / max(self.free_states, 1)

    @cached_property
    def no_safe_start(self) -> np.ndarray:
        """Target points (m, 2) with some free orientation but none in the kernel."""
        mask = self.grid.free.any(axis=1) & ~self.kernel.any(axis=1)
        return self.grid.points[mask]

    # ----- depth (for the controller and the evader) ---------------------------------------
    @cached_property
    def depth(self) -> np.ndarray:
        """Signed Euclidean depth (map units) of every lattice state in the kernel, shape
        ``(ny, nx, n_a + 1)`` (last plane repeats the first): distance to the nearest state
        outside, minus the distance to the nearest state inside; orientation distances are
        arc lengths ``lss·Δa`` at the observer."""
        from scipy.ndimage import distance_transform_edt

        ny, nx, n_a = self.grid.shape
        full = np.zeros((ny, nx, n_a), dtype=bool)
        ij = self.grid.ij
        full[ij[:, 1], ij[:, 0]] = self.kernel
        pad = n_a // 2
        wrapped = np.concatenate([full[..., -pad:], full, full[..., :pad]], axis=2)
        wrapped = np.pad(wrapped, ((1, 1), (1, 1), (0, 0)), constant_values=False)
        sampling = (self.grid.h, self.grid.h, self.lss * self.grid.delta)
        if wrapped.any():
            inside = distance_transform_edt(wrapped, sampling=sampling)
        else:
            inside = np.zeros(wrapped.shape)
        if (~wrapped).any():
            outside = distance_transform_edt(~wrapped, sampling=sampling)
        else:
            outside = np.zeros(wrapped.shape)
        d = (inside - outside)[1:-1, 1:-1, pad:pad + n_a]
        return np.concatenate([d, d[..., :1]], axis=2)

    def depth_at(self, points: Any, angles: Any) -> np.ndarray:
        """Signed depth (map units) at configurations ``(x, y, a)``, trilinear between lattice
        states; points off the lattice get the nearest lattice value."""
        from scipy.ndimage import map_coordinates

        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        ang = np.broadcast_to(np.asarray(angles, dtype=float), (len(pts),))
        ny, nx, n_a = self.grid.shape
        cx = np.clip((pts[:, 0] - self.grid.origin[0]) / self.grid.h, 0, nx - 1)
        cy = np.clip((pts[:, 1] - self.grid.origin[1]) / self.grid.h, 0, ny - 1)
        ca = np.mod(ang / self.grid.delta, n_a)
        return map_coordinates(self.depth, np.vstack([cy, cx, ca]), order=1, mode="nearest")

    # ----- L* -----------------------------------------------------------------------------
    def critical_distance(self, escape: Any, toward: Any, angle: float, goal: float | None = None,
                          samples: int = 400) -> dict:
        """``L*`` along the segment from ``toward`` (a start point) to the escape point
        ``escape``, at rod orientation ``angle``: walking from the start toward the escape
        point, the distance to it at which the state first leaves the kernel.

        Returns a dict with ``l_star`` (map units; ``None`` if the start itself is outside the
        kernel, ``0`` if the whole segment is inside) and, when ``goal`` (the goal orientation
        at the escape point) is given, the paper's ``L`` and the safe ``L_g`` of the faster
        rotation from ``angle`` to ``goal`` against a target heading for the escape point
        (:func:`tether.bounds.best_rotation`); ``L <= L* <= L_g`` is expected.
        """
        from tether.bounds import best_rotation

        q = np.asarray(escape, dtype=float)
        p0 = np.asarray(toward, dtype=float)
        total = float(np.hypot(*(p0 - q)))
        s = np.linspace(0.0, 1.0, samples)
        pts = p0[None, :] + s[:, None] * (q - p0)[None, :]
        inside = self.contains(pts, angle)
        if not inside[0]:
            l_star = None
        elif inside.all():
            l_star = 0.0
        else:
            first_out = int(np.argmin(inside))
            l_star = total * (1.0 - s[first_out])
        out: dict = {"l_star": l_star, "start_distance": total}
        if goal is not None:
            psi = math.atan2(q[1] - p0[1], q[0] - p0[0])
            rot = best_rotation(angle, goal, psi, self.vt, self.vo, self.lss)
            out.update({"L": rot.distance_bound, "L_g": rot.worst_case_distance,
                        "sense": rot.sense})
        return out

    # ----- persistence --------------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        """Write the kernel and its parameters to an ``.npz`` file (the map is stored as its
        JSON text so :func:`load_kernel` needs nothing else)."""
        import json

        g = self.grid
        np.savez_compressed(
            path, kernel=np.packbits(self.kernel, axis=1), n_a=g.n_a,
            level=self.level if self.level is not None else np.zeros((0, g.n_a), np.int32),
            params=np.array([self.lss, self.vt, self.vo, g.h, self.seconds]),
            meta=np.array(json.dumps({
                "scheme": self.scheme, "directions": self.directions,
                "iterations": self.iterations, "converged": self.converged,
                "history": list(self.history), "map": g.env.to_dict()})))


def load_kernel(path: str | Path) -> Kernel:
    """Read a kernel written by :meth:`Kernel.save` (the grid is rebuilt from the map).

    Examples
    --------
    >>> import os, tempfile
    >>> from tether import Environment
    >>> from tether.game import load_kernel, surveillance_kernel
    >>> ell = Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])  # an L-shaped room
    >>> kern = surveillance_kernel(ell, 0.5, vt=0.3, vo=1.0, h=0.25, orientations=36)
    >>> path = os.path.join(tempfile.mkdtemp(), "ell.npz")
    >>> kern.save(path)
    >>> again = load_kernel(path)
    >>> again.kernel_states == kern.kernel_states, bool((again.kernel == kern.kernel).all())
    (True, True)
    """
    import json

    from tether.io import from_dict

    with np.load(path, allow_pickle=False) as z:
        n_a = int(z["n_a"])
        lss, vt, vo, h, seconds = (float(x) for x in z["params"])
        meta = json.loads(str(z["meta"]))
        packed = z["kernel"]
        level = z["level"] if "level" in z.files else None
    env = from_dict(meta["map"])
    grid = build_grid(env, lss, h, n_a)
    kern = np.unpackbits(packed, axis=1, count=n_a).astype(bool)
    if level is not None and level.shape != kern.shape:
        level = None
    return Kernel(grid, kern, lss, vt, vo, meta["scheme"], meta["directions"],
                  meta["iterations"], meta["converged"], seconds, tuple(meta["history"]), level)


def _offsets(grid: StateGrid, lss: float, vt: float, vo: float, disp: np.ndarray, scheme: str
             ) -> tuple[np.ndarray, np.ndarray]:
    """Bin offsets ``[L_k, H_k]`` reachable from each bin ``k`` during the move ``disp``."""
    dist = float(np.hypot(*disp))
    tau = dist / vt
    v = disp / dist * vt
    lo, hi = rate_interval(v[None, :], grid.angles, lss, vo)
    delta = grid.delta
    if scheme == "inner":
        L = np.ceil(tau * lo / delta - 1e-9)
        H = np.floor(tau * hi / delta + 1e-9)
    else:
        e = delta / 2 + tau * tau * vt * vo / (lss * lss)
        L = np.ceil((tau * lo - e) / delta)
        H = np.floor((tau * hi + e) / delta)
    n_a = grid.n_a
    return (np.clip(L, -n_a, 0).astype(np.int64), np.clip(H, 0, n_a).astype(np.int64))


def _prefix(rows: np.ndarray) -> np.ndarray:
    """Prefix sums of three copies of each row: ``C[:, m]`` = kernel bins among the first
    ``m`` of the tripled circle."""
    tiled = np.tile(rows, (1, 3)).astype(np.int32)
    out = np.zeros((rows.shape[0], tiled.shape[1] + 1), dtype=np.int32)
    np.cumsum(tiled, axis=1, out=out[:, 1:])
    return out


def _any_in(C: np.ndarray, rows: np.ndarray, lo: np.ndarray, hi: np.ndarray, n_a: int
            ) -> np.ndarray:
    """Whether rows ``rows`` of the kernel have a bin in ``[k+lo, k+hi]`` for every ``k``."""
    k = np.arange(n_a)[None, :]
    r = rows[:, None]
    return C[r, k + hi + 1 + n_a] > C[r, k + lo + n_a]


def surveillance_kernel(env: Environment, lss: float, vt: float, vo: float, h: float | None = None,
                        orientations: int = 180, directions: int = 8, scheme: str = "inner",
                        max_iterations: int = 100000, grid: StateGrid | None = None) -> Kernel:
    """The discriminating kernel of the surveillance game on a grid.

    Parameters
    ----------
    env : Environment
    lss, vt, vo : float
        Rod length (map units) and speed bounds (map units/s), ``0 < vt < vo``.
    h : float, optional
        Lattice spacing, map units; default 1/100 of the larger side of the bounding box.
    orientations : int
        Number of orientation bins (default 180, 2° each).
    directions : int
        Target headings: 8 (lattice neighbours) or 16 (adding knight moves). The 16-move
        game keeps the 8 moves unchanged and gives the target more, so on the same grid its
        kernel is a subset of the 8-move kernel (more conservative, closer to the continuous
        game; tested).
    scheme : ``"inner"`` or ``"outer"``
        Rounding of the observer's reachable orientations: conservative (default) or
        optimistic; see the module docstring.
    max_iterations : int
        Stop (``converged=False``) after this many iterations.
    grid : StateGrid, optional
        A grid built by :func:`~tether.game.grid.build_grid` for the same map and ``lss``
        (reused across speeds).

    Returns
    -------
    Kernel

    Raises
    ------
    InvalidParameterError
        On invalid speeds (``vo <= vt``), lengths, grid sizes or an unknown scheme.

    Examples
    --------
    A coarse grid (spacing 0.25 map units, 10° bins) of an L-shaped room: with ``vt/vo = 0.3``
    nearly every free state is in the kernel; in a 1.5 × 3 room none is.

    >>> from tether import Environment
    >>> from tether.game import surveillance_kernel
    >>> ell = Environment([(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)])  # an L-shaped room
    >>> kern = surveillance_kernel(ell, 0.5, vt=0.3, vo=1.0, h=0.25, orientations=36)
    >>> kern.converged, round(kern.kernel_states / kern.free_states, 3)
    (True, 0.996)
    >>> kern.contains([(1.0, 1.0)], [0.0]).tolist()  # the state (x, y, a)
    [True]
    >>> room = Environment([(0, 0), (1.5, 0), (1.5, 3), (0, 3)])
    >>> surveillance_kernel(room, 1.0, vt=0.3, vo=1.0, h=0.1, orientations=36).kernel_states
    0
    """
    t0 = time.perf_counter()
    vt, vo, lss = check_speeds(vt, vo, lss)
    if scheme not in SCHEMES:
        raise InvalidParameterError(f"scheme must be one of {SCHEMES}, got {scheme!r}")
    if grid is None:
        if h is None:
            xmin, ymin, xmax, ymax = env.bounds
            h = max(xmax - xmin, ymax - ymin) / 100
        grid = build_grid(env, lss, h, orientations)
    n_a = grid.n_a
    P = grid.n_points
    moves = []
    for disp, src, dst, c_lo, c_hi in grid.continuations(directions):
        L, H = _offsets(grid, lss, vt, vo, disp, scheme)
        lo = np.maximum(L[None, :], c_lo)
        hi = np.minimum(H[None, :], c_hi)
        moves.append((src, dst, lo, hi))
    K = grid.free.copy()
    level = np.where(K, IN_KERNEL, 0).astype(np.int32)
    C = _prefix(K)
    dirty = K.any(axis=1)
    history = [int(K.sum())]
    iterations = 0
    converged = False
    while iterations < max_iterations:
        iterations += 1
        newK = K.copy()
        for src, dst, lo, hi in moves:
            sel = dirty[src] & K[src].any(axis=1) if len(src) else np.zeros(0, dtype=bool)
            if not sel.any():
                continue
            newK[src[sel]] &= _any_in(C, dst[sel], lo[sel], hi[sel], n_a)
        changed = np.flatnonzero((newK != K).any(axis=1))
        level[changed] = np.where(K[changed] & ~newK[changed], iterations, level[changed])
        K = newK
        history.append(int(K.sum()))
        if len(changed) == 0:
            converged = True
            break
        C[changed] = _prefix(K[changed])
        was = np.zeros(P, dtype=bool)
        was[changed] = True
        dirty = np.zeros(P, dtype=bool)
        for src, dst, _, _ in moves:
            dirty[src[was[dst]]] = True
    return Kernel(grid, K, lss, vt, vo, scheme, directions, iterations, converged,
                  time.perf_counter() - t0, tuple(history), level)
