"""Numpy helpers for ragged (CSR-style) integer arrays and grouped rows, shared by the curves,
the decomposition, G and the elimination: no Python loop over the rows."""

from __future__ import annotations

import numpy as np

__all__ = ["components", "first_max_per_group", "first_nearest", "first_per_group",
           "ragged_arange", "row_ids"]


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


def row_ids(key: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """An integer id per row of ``key`` (shape (n, k), floats or integers), equal for equal
    rows (compared as numbers), and the first row of each id (ids are numbered in no
    particular order). One stable sort on a 64-bit hash of the rows, verified (rows of equal
    hash must be equal, else a lexsort): ``np.unique`` on rows viewed as bytes compares them
    as strings, several times slower, and a lexsort sorts once per column."""
    n = len(key)
    if n == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    if key.dtype.kind == "f":
        bits = np.ascontiguousarray(key + 0.0).view(np.uint64)  # + 0.0: -0.0 becomes 0.0
    else:
        bits = np.ascontiguousarray(key).astype(np.int64).view(np.uint64)
    h = np.zeros(n, np.uint64)
    with np.errstate(over="ignore"):
        for j in range(key.shape[1]):
            h = (h ^ bits[:, j]) * np.uint64(0x9E3779B97F4A7C15)
            h ^= h >> np.uint64(29)
    order = np.argsort(h, kind="stable")
    sh = h[order]
    sk = key[order]
    new = np.empty(n, bool)
    new[0] = True
    new[1:] = sh[1:] != sh[:-1]
    if np.any(~new[1:] & np.any(sk[1:] != sk[:-1], axis=1)):  # a collision: sort the rows
        order = np.lexsort(key.T[::-1])
        sk = key[order]
        new[1:] = np.any(sk[1:] != sk[:-1], axis=1)
    ids = np.empty(n, np.int64)
    ids[order] = np.cumsum(new) - 1
    return ids, order[new]


def first_max_per_group(value: np.ndarray, group: np.ndarray) -> np.ndarray:
    """For ``group`` sorted (runs of equal values, all present from 0), the index of the
    first largest ``value`` of each run: ``np.lexsort((-value, group))``'s first row per run,
    without the sort."""
    if len(value) == 0:
        return np.zeros(0, np.int64)
    start = np.flatnonzero(np.r_[True, group[1:] != group[:-1]])
    top = np.maximum.reduceat(value, start)
    run = np.cumsum(np.r_[True, group[1:] != group[:-1]]) - 1
    hit = np.flatnonzero(value == top[run])
    return hit[np.r_[True, run[hit][1:] != run[hit][:-1]]]


def components(n: int, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Connected components of the graph on ``n`` nodes with edges ``u[k]-v[k]``: a label per
    node (the smallest node of its component). Min-label propagation with pointer jumping,
    in numpy (scipy.sparse would cost 0.2 s of import on every CLI call)."""
    label = np.arange(n)
    while True:
        m = np.minimum(label[u], label[v])
        new = label.copy()
        np.minimum.at(new, u, m)
        np.minimum.at(new, v, m)
        new = new[new]  # pointer jumping
        if np.array_equal(new, label):
            return label
        label = new
