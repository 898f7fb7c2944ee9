"""The state grid of the surveillance game: target points × rod orientations
(``docs/formulas.md``, "The surveillance kernel").

Target points are the centres of a square lattice of spacing ``h`` over the map's bounding box,
kept where they lie strictly inside the free space. Orientations are ``n_a`` bin centres
``a_k = k·δ``, ``δ = 2π/n_a``. A state ``(i, k)`` is *free* when the rod from point ``i`` at
``a_k`` lies in the free space, decided by the exact free arcs (:func:`tether.arcs.free_arcs_many`),
not by sampling. Each free state also records its *run*: the bins of the same exact free arc,
as offsets ``run_lo[i, k] <= 0 <= run_hi[i, k]`` from ``k``. The rod can rotate from ``a_k`` to
any bin of its run without touching an obstacle; two arcs separated by a gap narrower than a
bin stay two runs.

The target moves between lattice neighbours: 8 directions (axis and diagonal neighbours) or 16
(adding the knight moves). A move is allowed when its end is a grid point and its midpoint
(and quarter points) lie in the free space.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from tether.arcs import check_lss, free_arcs_many
from tether.environment import Environment
from tether.errors import InvalidParameterError
from tether.tolerances import ANGLE_TOL

__all__ = ["MOVES", "StateGrid", "build_grid", "lattice"]


#: Lattice displacements of the target moves, by number of directions.
MOVES = {
    8: ((1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1)),
    16: ((1, 0), (2, 1), (1, 1), (1, 2), (0, 1), (-1, 2), (-1, 1), (-2, 1),
         (-1, 0), (-2, -1), (-1, -1), (-1, -2), (0, -1), (1, -2), (1, -1), (2, -1)),
}


@dataclass(frozen=True, eq=False)
class StateGrid:
    """The grid over ``(x, y, a)``; see the module docstring.

    Attributes
    ----------
    origin : (x0, y0)
        Centre of lattice cell ``(0, 0)``, map units.
    h : float
        Lattice spacing, map units.
    shape : (ny, nx, n_a)
    index : ndarray (ny, nx) of int
        Point index of each lattice cell, ``-1`` where the centre is not strictly free.
    points : ndarray (P, 2)
        The grid's target points, map units; ``ij[P, 2]`` their lattice ``(ix, iy)``.
    free, run_lo, run_hi : ndarray (P, n_a)
        Free-state mask and the run offsets (int16, in ``[-n_a, n_a]``; full circle: ``±n_a``).
    """

    env: Environment
    lss: float
    origin: tuple[float, float]
    h: float
    shape: tuple[int, int, int]
    index: np.ndarray
    points: np.ndarray
    ij: np.ndarray
    free: np.ndarray
    run_lo: np.ndarray
    run_hi: np.ndarray
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def n_a(self) -> int:
        """Number of orientation bins."""
        return self.shape[2]

    @property
    def delta(self) -> float:
        """Orientation bin width, radians."""
        return math.tau / self.n_a

    @property
    def angles(self) -> np.ndarray:
        """Bin centres ``k·δ``, radians."""
        return np.arange(self.n_a) * self.delta

    @property
    def n_points(self) -> int:
        """Number of lattice points kept (strictly inside the free space)."""
        return len(self.points)

    def to_dict(self) -> dict:
        """The grid's parameters as JSON-ready values (``h`` and origin in map units)."""
        return {"h": self.h, "orientations": self.n_a, "shape": list(self.shape),
                "origin": list(self.origin)}

    def point_at(self, points: np.ndarray) -> np.ndarray:
        """Index of the nearest grid point of each point (shape (m, 2)), ``-1`` where that
        lattice cell is not a grid point or lies outside the lattice."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        ny, nx, _ = self.shape
        ix = np.rint((pts[:, 0] - self.origin[0]) / self.h).astype(np.int64)
        iy = np.rint((pts[:, 1] - self.origin[1]) / self.h).astype(np.int64)
        ok = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
        out = np.full(len(pts), -1, dtype=np.int64)
        out[ok] = self.index[iy[ok], ix[ok]]
        return out

    def bin_at(self, angles: np.ndarray) -> np.ndarray:
        """Nearest orientation bin of each angle (radians)."""
        return np.mod(np.rint(np.asarray(angles, dtype=float) / self.delta), self.n_a).astype(
            np.int64)

    def moves(self, directions: int) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """The target moves: for each lattice direction ``d``, ``(disp, src, dst)`` with the
        displacement ``disp`` (map units) and the point indices of every allowed move."""
        if directions not in MOVES:
            raise InvalidParameterError(f"directions must be one of {sorted(MOVES)}, "
                                        f"got {directions!r}")
        ny, nx, _ = self.shape
        out = []
        for dx, dy in MOVES[directions]:
            ix, iy = self.ij[:, 0] + dx, self.ij[:, 1] + dy
            ok = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
            src = np.flatnonzero(ok)
            dst = self.index[iy[ok], ix[ok]]
            keep = dst >= 0
            src, dst = src[keep], dst[keep]
            disp = np.array([dx, dy], dtype=float) * self.h
            for f in (0.25, 0.5, 0.75):
                mid = self.points[src] + f * disp
                inside = self.env.contains(mid[:, 0], mid[:, 1])
                src, dst = src[inside], dst[inside]
            out.append((disp, src, dst))
        return out

    def continuations(self, directions: int
                      ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
        """For each target move, where the rod's free run can be carried to.

        Returns, per lattice direction, ``(disp, src, dst, c_lo, c_hi)``: for a free state
        ``(src[m], k)`` the bins ``k + c_lo[m, k] .. k + c_hi[m, k]`` (offsets, int16) at
        ``dst[m]`` are reachable by a continuous free motion with unlimited rotation: rotate
        within the run at the start, translate half a step at a fixed orientation free at the
        move's midpoint, rotate within the run there, translate on, rotate within the run at
        the end. The runs met on the way are taken as their hull (optimistic only where an
        arc splits within the step: within a cell of a critical curve). ``c_lo > c_hi`` when
        nothing can be carried. Without the midpoint an arc that turns faster than its width
        per step (the target passing close to a reflex vertex) would be cut for nothing.
        Computed once per ``directions`` and cached on the grid.
        """
        if directions not in self._cache:
            self._cache[directions] = self._continuations(directions)
        return self._cache[directions]

    def _continuations(self, directions: int) -> list:
        n_a = self.n_a
        out = []
        for disp, src, dst in self.moves(directions):
            k = np.arange(n_a)[None, :]
            lo = k + self.run_lo[src].astype(np.int64)
            hi = k + self.run_hi[src].astype(np.int64)
            mids = self.points[src] + disp / 2
            mfree, mlo, mhi = _runs(self.env, mids, self.lss, n_a)
            lo, hi = _carry(lo, hi, k, mfree, mlo, mhi)
            lo, hi = _carry(lo, hi, k, self.free[dst], self.run_lo[dst], self.run_hi[dst])
            out.append((disp, src, dst, np.clip(lo - k, -n_a - 1, n_a).astype(np.int16),
                        np.clip(hi - k, -n_a - 1, n_a).astype(np.int16)))
        return out


def lattice(env: Environment, h: float) -> tuple[tuple[float, float], int, int]:
    """Origin and size ``(nx, ny)`` of the lattice of spacing ``h`` centred on the bounding box."""
    xmin, ymin, xmax, ymax = env.bounds
    nx = max(1, int(math.floor((xmax - xmin) / h)))
    ny = max(1, int(math.floor((ymax - ymin) / h)))
    x0 = xmin + ((xmax - xmin) - (nx - 1) * h) / 2
    y0 = ymin + ((ymax - ymin) - (ny - 1) * h) / 2
    return (x0, y0), nx, ny


def build_grid(env: Environment, lss: float, h: float, orientations: int) -> StateGrid:
    """The state grid with its exact free-state mask and runs.

    Parameters
    ----------
    env : Environment
    lss : float
        Rod length, map units.
    h : float
        Lattice spacing, map units (> 0).
    orientations : int
        Number of orientation bins (>= 8).

    Raises
    ------
    InvalidParameterError
        On a non-positive ``h``, fewer than 8 orientations, or a grid of more than 2e7 states.
    """
    lss = check_lss(lss)
    if not (isinstance(h, (int, float)) and math.isfinite(h) and h > 0):
        raise InvalidParameterError(f"h must be a finite number > 0, got {h!r}")
    n_a = int(orientations)
    if n_a < 8:
        raise InvalidParameterError(f"orientations must be >= 8, got {orientations!r}")
    origin, nx, ny = lattice(env, float(h))
    if nx * ny * n_a > 2e7:
        raise InvalidParameterError(
            f"grid of {nx}×{ny}×{n_a} states is too large (limit 2e7): increase h")
    gx, gy = np.meshgrid(origin[0] + h * np.arange(nx), origin[1] + h * np.arange(ny))
    inside = env.contains(gx, gy) & (env.boundary_distance(gx, gy) > 10 * env.length_tol)
    iy, ix = np.nonzero(inside)
    index = np.full((ny, nx), -1, dtype=np.int64)
    index[iy, ix] = np.arange(len(ix))
    pts = np.column_stack([gx[iy, ix], gy[iy, ix]])
    free, run_lo, run_hi = _runs(env, pts, lss, n_a)
    return StateGrid(env, lss, origin, float(h), (ny, nx, n_a), index, pts,
                     np.column_stack([ix, iy]), free, run_lo, run_hi)


def _carry(lo: np.ndarray, hi: np.ndarray, k: np.ndarray, free: np.ndarray, run_lo: np.ndarray,
           run_hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Carry unwrapped bin intervals ``[lo, hi]`` (rows of states) to the next point: the hull
    of the runs there that meet the interval (``lo > hi`` stays empty)."""
    n_a = free.shape[1]
    lo = np.clip(lo, k - n_a, k + n_a)
    hi = np.clip(hi, k - n_a, k + n_a)
    tri = np.tile(free, (1, 3))  # tripled circle: unwrapped bin x at column x + n_a
    cols = np.arange(3 * n_a)[None, :]
    big = 10 * n_a
    nxt = np.minimum.accumulate(np.where(tri, cols, big)[:, ::-1], axis=1)[:, ::-1]
    prv = np.maximum.accumulate(np.where(tri, cols, -big), axis=1)
    rows = np.arange(len(free))[:, None]
    x0 = np.clip(lo + n_a, 0, 3 * n_a - 1)
    x1 = np.clip(hi + n_a, 0, 3 * n_a - 1)
    y0 = nxt[rows, x0]
    y1 = prv[rows, x1]
    ok = (lo <= hi) & (y0 <= x1) & (y0 < big)
    y0 = np.where(ok, y0, n_a) - n_a  # back to unwrapped bins
    y1 = np.where(ok, y1, n_a) - n_a
    new_lo = y0 + run_lo[rows, np.mod(y0, n_a)]
    new_hi = y1 + run_hi[rows, np.mod(y1, n_a)]
    return np.where(ok, new_lo, k + 1), np.where(ok, new_hi, k)


def _runs(env: Environment, pts: np.ndarray, lss: float, n_a: int
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Free mask and run offsets from the exact arcs: bin ``k`` is free when its centre lies in
    a free arc; its run is the bins of that arc."""
    P = len(pts)
    free = np.zeros((P, n_a), dtype=bool)
    run_lo = np.zeros((P, n_a), dtype=np.int16)
    run_hi = np.zeros((P, n_a), dtype=np.int16)
    if P == 0:
        return free, run_lo, run_hi
    table = free_arcs_many(env, pts, lss, check=False)
    delta = math.tau / n_a
    length = np.mod(table.end - table.start, math.tau)
    # arcs shorter than the angle tolerance are never emitted: one whose ends coincide is the
    # whole circle but for a grazing contact (a point exactly ``lss`` from a vertex)
    length = np.where(length <= ANGLE_TOL, math.tau, length)
    k0 = np.ceil(table.start / delta - 1e-12).astype(np.int64)
    k1 = np.floor((table.start + length) / delta + 1e-12).astype(np.int64)
    count = np.clip(k1 - k0 + 1, 0, n_a)
    row = np.repeat(np.arange(len(k0)), count)
    first = np.repeat(np.cumsum(count) - count, count)
    j = k0[row] + (np.arange(len(row)) - first)  # unwrapped bin
    p = table.point[row]
    b = np.mod(j, n_a)
    free[p, b] = True
    run_lo[p, b] = np.maximum(k0[row] - j, -n_a)
    run_hi[p, b] = np.minimum(k0[row] + count[row] - 1 - j, n_a)
    full = np.flatnonzero(table.full)
    free[full] = True
    run_lo[full] = -n_a
    run_hi[full] = n_a
    return free, run_lo, run_hi
