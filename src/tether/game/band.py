"""The undecided band: the states between the certified kernel and the optimistic one.

The certified kernel (:mod:`tether.game.certified`) is a subset of the true kernel; the
optimistic grid kernel (:func:`tether.game.kernel.surveillance_kernel` with
``scheme="outer"``) is taken as a superset (the game that gives the target fewer moves). The
states in the second and not in the first are *undecided*: tether claims neither that they
are safe nor that they are lost. :func:`undecided_band` measures that set on the optimistic
kernel's own lattice, where it is defined state by state:

- its *share*: undecided states over the free states (target in the free space, rod free),
  and its *volume* in map units² · radians (each lattice state standing for ``h² · δ``,
  ``δ`` the orientation bin);
- its *reach*: at each orientation bin, the largest distance (map units) from an undecided
  lattice point to the nearest decided one (certified, or outside the optimistic kernel, or
  not free), by a Euclidean distance transform of the bin's slice on the lattice. The band
  is at most about twice its reach wide, and refining where the reach is large is what
  shrinks it.

A state's class is taken at the lattice point and the bin's centre; the share and the reach
are therefore those of the lattice's sample of the band (resolution ``h`` and ``δ``), not of
the continuous set.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.ndimage import distance_transform_edt

__all__ = ["Band", "undecided_band"]


@dataclass(frozen=True)
class Band:
    """Result of :func:`undecided_band`.

    Attributes
    ----------
    free_states, certified_states, undecided_states, unsafe_states : int
        Lattice states (point, orientation bin) that are free, and how they split.
    volume : float
        The undecided states' volume, map units² · radians.
    reach : float
        The largest distance from an undecided state to a decided one at the same
        orientation bin, map units (0 when nothing is undecided).
    reach_95 : float
        The 95th percentile of that distance over the undecided states, map units.
    h : float
        The lattice spacing the band is measured on, map units.
    contradictions : int
        Certified states outside the optimistic kernel (counted as certified): 0 when the
        two kernels bracket each other as they should; more means one of the two games
        is wrong there, or the lattice cannot tell (a state within a bin of the boundary).
    """

    free_states: int
    certified_states: int
    undecided_states: int
    unsafe_states: int
    volume: float
    reach: float
    reach_95: float
    h: float
    contradictions: int = 0

    @property
    def share(self) -> float:
        """Undecided states over free states (0 when no state is free)."""
        return self.undecided_states / self.free_states if self.free_states else 0.0

    def to_dict(self) -> dict:
        """JSON-ready fields (``tether kernel --certified --json``'s ``band``)."""
        return {"free_states": self.free_states, "certified_states": self.certified_states,
                "undecided_states": self.undecided_states, "unsafe_states": self.unsafe_states,
                "share": self.share, "volume": self.volume, "reach": self.reach,
                "reach_95": self.reach_95, "h": self.h,
                "contradictions": self.contradictions}


def lattice_classes(certified: Any, optimistic: Any) -> tuple[np.ndarray, np.ndarray]:
    """Certified and undecided masks ``(P, n_a)`` over the optimistic kernel's lattice states
    (point ``optimistic.grid.points[i]``, orientation ``optimistic.grid.angles[k]``)."""
    grid = optimistic.grid
    n_p, n_a = grid.free.shape
    pts = np.repeat(grid.points, n_a, axis=0)
    ang = np.tile(grid.angles, n_p)
    safe = certified.contains(pts, ang).reshape(n_p, n_a) & grid.free
    undecided = optimistic.kernel & grid.free & ~safe
    return safe, undecided


def undecided_band(certified: Any, optimistic: Any) -> Band:
    """Measure the undecided band of ``certified`` (a
    :class:`~tether.game.certified.CertifiedKernel`) against ``optimistic`` (a grid
    :class:`~tether.game.kernel.Kernel` of scheme ``"outer"``) on the latter's lattice.

    Examples
    --------
    >>> from tether import Environment
    >>> from tether.game import surveillance_kernel
    >>> from tether.game.certified import certified_kernel
    >>> room = Environment([(0, 0), (6, 0), (6, 6), (0, 6)])
    >>> ck = certified_kernel(room, 1.0, vt=0.3, vo=1.0, h=0.5)  # doctest: +SKIP
    >>> outer = surveillance_kernel(room, 1.0, 0.3, 1.0, h=0.5, scheme="outer")  # doctest: +SKIP
    >>> undecided_band(ck, outer).share < 0.2  # doctest: +SKIP
    True
    """
    grid = optimistic.grid
    safe, undecided = lattice_classes(certified, optimistic)
    n_free = int(grid.free.sum())
    n_safe, n_und = int(safe.sum()), int(undecided.sum())
    dists = _band_distances(grid, undecided)
    return Band(free_states=n_free, certified_states=n_safe, undecided_states=n_und,
                unsafe_states=n_free - n_safe - n_und,
                volume=n_und * grid.h ** 2 * grid.delta,
                reach=float(dists.max()) if len(dists) else 0.0,
                reach_95=float(np.percentile(dists, 95)) if len(dists) else 0.0,
                h=float(grid.h),
                contradictions=int((safe & ~optimistic.kernel).sum()))


def _band_distances(grid: Any, undecided: np.ndarray) -> np.ndarray:
    """For every undecided state, its distance (map units) to the nearest lattice point of
    the same orientation bin that is not undecided (lattice points off the free space count
    as decided: their states are not in the optimistic kernel)."""
    ny, nx, n_a = grid.shape
    iy, ix = grid.ij[:, 1], grid.ij[:, 0]
    out = []
    for k in np.flatnonzero(undecided.any(axis=0)):
        # pad by one decided ring so that the lattice's edge counts as decided
        slab = np.zeros((ny + 2, nx + 2), dtype=bool)
        rows = undecided[:, k]
        slab[iy[rows] + 1, ix[rows] + 1] = True
        d = distance_transform_edt(slab)
        out.append(d[iy[rows] + 1, ix[rows] + 1])
    return np.concatenate(out) * grid.h if out else np.empty(0)
