"""Numpy helpers for ragged (CSR-style) integer arrays and grouped rows, shared by the curves,
the decomposition, G and the elimination: no Python loop over the rows."""

from __future__ import annotations

import numpy as np

__all__ = ["first_nearest", "first_per_group", "ragged_arange"]


def ragged_arange(starts: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """``concatenate([arange(s, s + c) for s, c in zip(starts, counts)])``, vectorized."""
    counts = np.asarray(counts, dtype=np.int64)
    total = int(counts.sum())
    if total == 0:
        return np.zeros(0, dtype=np.int64)
    offs = np.cumsum(counts) - counts
    return np.repeat(np.asarray(starts, np.int64) - offs, counts) + np.arange(total)


def first_per_group(rows: np.ndarray, group: np.ndarray) -> np.ndarray:
    """The first of ``rows`` (increasing) of each value of ``group[rows]`` (increasing)."""
    g = group[rows]
    return rows[np.r_[True, g[1:] != g[:-1]]]


def first_nearest(row: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """For rows ``row`` (increasing, each present), the index of each row's smallest
    ``dist``, the first among equals (as a stable sort by (row, dist) picks it; a lexsort
    if some distance is nan)."""
    if np.isnan(dist).any():
        order = np.lexsort((dist, row))
        return order[np.r_[True, row[order][1:] != row[order][:-1]]]
    start = np.flatnonzero(np.r_[True, row[1:] != row[:-1]])
    least = np.minimum.reduceat(dist, start)
    hit = np.flatnonzero(dist == np.repeat(least, np.diff(np.r_[start, len(row)])))
    return first_per_group(hit, row)
