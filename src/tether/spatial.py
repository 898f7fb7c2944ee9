"""A uniform-grid index of the map's edges, for "which edges are within reach of these points".

Every query in tether is of one shape: many points, one reach (the rod length). A grid whose
cells are about half the reach, with each edge registered in every cell within reach of it,
answers that query for a million points with a few numpy operations and no Python loop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Upper bound on the number of grid cells (memory guard for tiny reaches on large maps).
MAX_CELLS = 4_000_000


@dataclass(frozen=True, eq=False)
class EdgeIndex:
    """Edges registered in grid cells; ``query`` returns candidate (point, edge) pairs.

    Every edge within ``reach`` of a point is among its candidates (a superset: callers test
    exactly).
    """

    origin: np.ndarray
    cell: float
    shape: tuple[int, int]
    start: np.ndarray  # CSR offsets, length ncells + 1
    edges: np.ndarray  # edge ids, grouped by cell

    @classmethod
    def build(cls, a: np.ndarray, b: np.ndarray, reach: float) -> EdgeIndex:
        """Index segments ``a[i]-b[i]`` (shape (n, 2)) for queries of radius ``reach``."""
        lo = np.minimum(a, b).min(axis=0) - reach
        hi = np.maximum(a, b).max(axis=0) + reach
        span = hi - lo
        cell = max(reach / 2.0, math.sqrt(span[0] * span[1] / MAX_CELLS), 1e-300)
        nx = max(1, math.ceil(span[0] / cell))
        ny = max(1, math.ceil(span[1] / cell))
        cells_of, edges_of = [], []
        half_diag = cell * math.sqrt(0.5)
        for i in range(len(a)):
            e_lo = (np.minimum(a[i], b[i]) - reach - lo) / cell
            e_hi = (np.maximum(a[i], b[i]) + reach - lo) / cell
            ix = np.arange(max(0, int(e_lo[0])), min(nx, int(e_hi[0]) + 1))
            iy = np.arange(max(0, int(e_lo[1])), min(ny, int(e_hi[1]) + 1))
            gx, gy = np.meshgrid(ix, iy, indexing="ij")
            centers = lo + (np.column_stack((gx.ravel(), gy.ravel())) + 0.5) * cell
            keep = _segment_distance(centers, a[i], b[i]) <= reach + half_diag
            cid = (gx.ravel() * ny + gy.ravel())[keep]
            cells_of.append(cid)
            edges_of.append(np.full(len(cid), i))
        cid = np.concatenate(cells_of) if cells_of else np.zeros(0, int)
        eid = np.concatenate(edges_of) if edges_of else np.zeros(0, int)
        order = np.argsort(cid, kind="stable")
        counts = np.bincount(cid, minlength=nx * ny)
        start = np.concatenate(([0], np.cumsum(counts)))
        return cls(lo, cell, (nx, ny), start, eid[order])

    def query(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Candidate pairs for points ``pts`` (shape (m, 2)).

        Returns
        -------
        point_idx, edge_idx : ndarray of int
            Row ``k`` says edge ``edge_idx[k]`` may be within reach of point ``point_idx[k]``;
            rows are grouped by point, in increasing point order.
        """
        nx, ny = self.shape
        g = np.floor((pts - self.origin) / self.cell).astype(np.int64)
        gx = np.clip(g[:, 0], 0, nx - 1)
        gy = np.clip(g[:, 1], 0, ny - 1)
        c = gx * ny + gy
        first = self.start[c]
        count = self.start[c + 1] - first
        pidx = np.repeat(np.arange(len(pts)), count)
        # position of each row within its point's run, added to that cell's first entry
        run_start = np.cumsum(count) - count
        within = np.arange(len(pidx)) - np.repeat(run_start, count)
        eidx = self.edges[np.repeat(first, count) + within]
        return pidx, eidx


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from points ``p`` (m, 2) to the segment ``a-b``."""
    d = b - a
    dd = float(d @ d)
    t = np.zeros(len(p)) if dd == 0 else np.clip((p - a) @ d / dd, 0.0, 1.0)
    return np.linalg.norm(p - (a + t[:, None] * d), axis=1)
