"""A first field for the search whose singularities sit where a whole-circle core fits
(``docs/certified.md``, "Where no field is certified", floor plans).

An arc field's gap direction winds: near a wall the gap holds the direction into the wall, so
its singularities carry a total index of ``1 − holes`` (Poincaré–Hopf), and each needs a
whole-circle core of radius about :func:`~tether.game.field_lp.vortex_radius` beyond the
``lss`` a whole-circle vertex keeps from the walls. :func:`~tether.game.certificate.first_field`
points each arc at the direction away from the nearest wall, which puts a saddle in every
passage narrower than about ``2·lss`` (no core fits there). Here the arcs' *run direction*
``d`` (a unit complex number per vertex, the gap at ``−d``) is a harmonic interpolation in the
spirit of Knöppel, Crane, Pinkall and Schröder ("Globally optimal direction fields", 2013):

- a vertex whose free orientations (:func:`~tether.game.certificate.star_bins`) form one run
  is pinned into that run (:data:`RUN_MARGIN` inside its ends; its middle only starts the
  iteration);
- in a passage narrower than twice the clearance a core needs (:func:`core_clearance` plus
  the mesh spacing, measured straight across from the nearest wall) a vertex keeps only the
  runs *along* the passage (within :data:`ALONG`); where that leaves two runs (both ways
  along), one is chosen per passage by a breadth-first walk through it from the direction a
  first solve gives (a *line* constraint whose sign the field chooses once per passage);
- whole-circle vertices are free.

``d`` minimizes ``Σ w_e·|d_i − d_j|²`` over the mesh's edges, ``w_e = (ℓ/c_e)^p`` (``c_e``
the clearance at the edge's middle, ``ℓ`` the mean edge length, ``p`` =
:data:`CLEARANCE_POWER`; scale-free), :data:`STIFF` times more where no core fits, plus the
pins, in :data:`UNIT_STEPS` steps: each pulls the free vertices towards unit length (a
harmonic field between opposite walls passes through zero, a unit one turns) and each pin
into its run, the pins weak at first (:data:`PIN_START`) and growing to :data:`PIN_PULL`.
Turning is dear near walls and cheap in the open, so the zeros of ``d`` (its singularities)
should move to the clear regions; ``docs/certified.md`` says where they do and where they do
not (a saddle a passage forces stays at its mouth).

The arcs are then the runs holding ``d`` (as :func:`~tether.game.certificate.first_field`
takes the run holding its direction), centred on ``d`` where it lies in its run, and the gap
of a whole-circle vertex is at ``−d``: the gap follows the singularities. The
mesh is :func:`~tether.game.certificate.first_field`'s, so the field can be handed to
:func:`~tether.game.field_lp.solve_field` as ``start`` or to
:func:`~tether.game.field_lp.lp_field`. Like any first field it proves nothing:
:func:`~tether.game.certificate.certify` decides.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from scipy import sparse
from scipy.sparse.csgraph import breadth_first_order, connected_components
from scipy.sparse.linalg import spsolve
from scipy.spatial import cKDTree

from tether.game.certificate import ArcField, first_field, runs_toward, star_bins
from tether.game.field_lp import aligned_radius, vortex_radius

__all__ = ["ALONG", "CLEARANCE_POWER", "PIN_PULL", "PIN_START", "RUN_MARGIN", "STIFF",
           "UNIT_PULL", "UNIT_STEPS", "core_clearance", "direction_field",
           "harmonic_directions", "run_middles", "singularities"]

#: Power of the clearance in the edge weights ``(ℓ/c)^p`` of the harmonic solve
CLEARANCE_POWER = 6
#: Steps of the iteration that pulls the free vertices' directions towards unit length, and
#: the pull's weight against the smoothness (per vertex, relative to its edge weights): a
#: harmonic field between opposite walls passes through zero along the whole strip, a unit
#: one turns across it
UNIT_STEPS = 30
UNIT_PULL = 1.0
#: The pull of a vertex with free orientations on one run (or a chosen run of a passage)
#: into that run, less :data:`RUN_MARGIN`: the run's middle is only where the iteration starts
PIN_PULL = 100.0
#: Half-width (radians) of the directions along a passage a vertex in one may take
ALONG = math.radians(45)
#: Weight factor of the edges where no core fits (the clearance below the core's, plus the
#: mesh spacing): a singularity costs that much more there
STIFF = 1e4
#: The pins' pull in the first step of the iteration, relative to :data:`PIN_PULL` (it
#: grows geometrically to 1 by the last step)
PIN_START = 1e-3
#: How far inside its run (radians, at most a quarter of the run) a vertex's direction is
#: pulled
RUN_MARGIN = math.radians(20)
_TAU = math.tau


def run_middles(bins: np.ndarray, delta: float) -> tuple[np.ndarray, list[np.ndarray]]:
    """Per row of ``bins`` ((n, n_a) bool, bin ``k`` the orientation ``k·delta`` radians): the
    number of circular runs of ``True`` (0 for a full or an empty row) and, per row, the
    middles of its runs (radians)."""
    n_a = bins.shape[1]
    starts = bins & ~np.roll(bins, 1, axis=1)
    count = starts.sum(axis=1)
    mids = []
    for row, st in zip(bins, starts, strict=True):
        ks = np.flatnonzero(st)
        m = []
        for k in ks:
            length = int(np.argmin(np.roll(row, -k))) if not row.all() else n_a
            m.append((k + (length - 1) / 2) * delta)
        mids.append(np.array(m))
    return count, mids


def _edges(tri: np.ndarray) -> np.ndarray:
    return np.unique(np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [0, 2]]]),
                             axis=1), axis=0)


def harmonic_directions(points: np.ndarray, tri: np.ndarray, clearance: np.ndarray,
                        fixed: np.ndarray, value: np.ndarray,
                        power: float = CLEARANCE_POWER, pull: float | np.ndarray = 0.0,
                        target: np.ndarray | None = None, stiff: float | None = None
                        ) -> np.ndarray:
    """The complex field ``z`` (one per vertex) equal to ``value`` where ``fixed`` and
    minimizing ``Σ w_e·|z_i − z_j|²`` elsewhere, ``w_e = (ℓ/c_e)^power`` (``c_e`` the
    ``clearance``, map units, at the middle of edge ``e``, interpolated from its two vertices
    and at least a quarter of the mean edge length ``ℓ``). A free component without a fixed
    vertex gets 0. With a ``target``, ``pull`` (a number or one per vertex) adds
    ``pull_i·d_i·|z_i − target_i|²`` at the free vertices (``d_i`` the vertex's total edge
    weight): a step of the projected iteration of :func:`direction_field`. ``stiff`` (map
    units): the edges whose clearance is below it weigh :data:`STIFF` times more."""
    e = _edges(tri)
    length = np.hypot(*(points[e[:, 0]] - points[e[:, 1]]).T)
    ell = float(length.mean())
    c = np.maximum((clearance[e[:, 0]] + clearance[e[:, 1]]) / 2, ell / 4)
    w = (ell / c) ** power
    if stiff is not None:  # no singularity where no core fits
        w = np.where(c < stiff, STIFF * w, w)
    n = len(points)
    free = ~fixed
    fi = np.flatnonzero(free)
    if not len(fi):
        return value.astype(complex)
    idx = np.full(n, -1)
    idx[fi] = np.arange(len(fi))
    rows, cols, vals = [], [], []
    diag = np.zeros(len(fi))
    rhs = np.zeros(len(fi), dtype=complex)
    for u, v in ((e[:, 0], e[:, 1]), (e[:, 1], e[:, 0])):
        at = free[u]
        u, v, wu = u[at], v[at], w[at]
        np.add.at(diag, idx[u], wu)
        both = free[v]
        rows.append(idx[u[both]])
        cols.append(idx[v[both]])
        vals.append(-wu[both])
        np.add.at(rhs, idx[u[~both]], wu[~both] * value[v[~both]])
    rows.append(np.arange(len(fi)))
    cols.append(np.arange(len(fi)))
    if target is not None:
        k = np.broadcast_to(np.asarray(pull, float), (n,))[fi]
        rhs = rhs + k * diag * target[fi]
        diag = diag * (1 + k)
    vals.append(diag + 1e-12 * max(float(diag.max()), 1.0))  # a component with no fixed vertex
    m = sparse.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                          shape=(len(fi), len(fi))).tocsc()
    z = value.astype(complex).copy()
    z[fi] = spsolve(m, rhs)
    return z


def singularities(z: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """The index of the direction field ``arg z`` around each triangle (an integer per
    triangle: the wrapped turns along its three edges over 2π; 0 where it does not wind)."""
    a = np.angle(z)[tri]
    turn = sum(np.mod(a[:, (k + 1) % 3] - a[:, k] + math.pi, _TAU) - math.pi for k in range(3))
    return np.rint(turn / _TAU).astype(int)


def direction_field(kern, grow: float = 0.0, power: float = CLEARANCE_POWER
                    ) -> tuple[ArcField, np.ndarray]:
    """The first field of the module docstring on the mesh of
    :func:`~tether.game.certificate.first_field` of ``kern`` (a conservative grid kernel;
    ``grow``: a sensing delay's ``vt·d``, map units). Returns ``(field, z)``: the arcs and the
    run direction per vertex (complex; the gap of a whole-circle vertex at ``−z``)."""
    grid = kern.grid
    f0 = first_field(kern, grow)
    pts, tri = f0.points, f0.tri
    dist, near = cKDTree(grid.points).query(pts)
    src = np.where(dist == 0, near, -1)
    bins, star_free = star_bins(kern, pts, tri, src, grow)
    count, mids = run_middles(bins, grid.delta)
    thin = ~(bins & np.roll(bins, 1, axis=1)).any(axis=1)  # no run of 2 bins
    if thin.any():  # the free bins alone where the kernel leaves none
        c2, m2 = run_middles(star_free[thin], grid.delta)
        count[thin] = c2
        for i, k in enumerate(np.flatnonzero(thin)):
            mids[k] = m2[i]
    clear = grid.env.boundary_distance(pts[:, 0], pts[:, 1])
    stiff = core_clearance(kern) + grid.h
    along = _along_passages(grid.env, pts, clear, stiff, grid.n_a)
    rows = np.where(thin[:, None], star_free, bins)
    narrowed = rows & along
    keep = (narrowed & np.roll(narrowed, 1, axis=1)).any(axis=1) & along.any(axis=1) \
        & ~along.all(axis=1)
    if keep.any():  # in a passage too narrow for a core: the runs along it only
        rows = np.where(keep[:, None], narrowed, rows)
        c3, m3 = run_middles(rows[keep], grid.delta)
        count[keep] = c3
        for i, k in enumerate(np.flatnonzero(keep)):
            mids[k] = m3[i]
    one = count == 1
    value = np.zeros(len(pts), dtype=complex)
    value[one] = np.exp(1j * np.array([m[0] for m in np.asarray(mids, dtype=object)[one]]))
    z = harmonic_directions(pts, tri, clear, one, value, power, stiff=stiff)
    many = np.flatnonzero(count >= 2)
    for order, pred in _passages(many, tri, z):  # along each passage, one way
        for i in order:  # the run nearest the direction of the vertex it is reached from
            toward = np.angle(z[i]) if pred[i] < 0 else np.angle(value[pred[i]])
            value[i] = np.exp(1j * mids[i][np.argmax(np.cos(mids[i] - toward))])
    fixed = one.copy()
    fixed[many] = True
    free = np.zeros(len(pts), bool)
    z = harmonic_directions(pts, tri, clear, free, value, power,  # the pins weak: the
                            np.where(fixed, PIN_PULL * PIN_START, 0.0), value, stiff)  # open
    s0, n0, _ = runs_toward(rows, np.mod(np.round(np.angle(value) / grid.delta),
                                          grid.n_a).astype(int))
    run_lo, run_w = s0 * grid.delta, np.maximum(n0 - 1, 0) * grid.delta
    for k in range(UNIT_STEPS):  # towards unit length, and into the runs (not their middle),
        ramp = PIN_START ** (1 - k / max(UNIT_STEPS - 1, 1))  # the pins weak at first: the
        pull = np.where(fixed, PIN_PULL * ramp, UNIT_PULL)  # singularities move to the open
        a = np.angle(z)
        a = np.where(fixed, _clamp(a, run_lo, run_w), a)
        target = np.where(fixed | (np.abs(z) > 0), np.exp(1j * a), 0)
        z = harmonic_directions(pts, tri, clear, free, value, power, pull, target, stiff)
    pref = np.mod(np.round(np.angle(z) / grid.delta), grid.n_a).astype(int)
    start, length, full = runs_toward(bins, pref)
    short = length <= 1
    if short.any():
        s2, l2, f2 = runs_toward(star_free[short], pref[short])
        start[short], length[short], full[short] = s2, l2, f2
    lo = np.where(full, np.mod(np.angle(z) + math.pi, _TAU), start * grid.delta)
    w = np.where(full, _TAU, np.maximum(length - 1, 0) * grid.delta)
    into = np.mod(np.angle(z) - lo, _TAU)  # the arc centred on z where z lies in its run:
    half = np.minimum(into, w - into)  # the gap then follows −z, as the singularities do
    centred = ~full & (into <= w) & (half >= grid.delta)
    lo = np.where(centred, np.angle(z) - half, lo)
    w = np.where(centred, 2 * half, w)
    return ArcField(pts, tri, lo, w), z



def core_clearance(kern) -> float:
    """The clearance (map units) a singularity's core needs: ``lss`` (a whole-circle vertex's
    own) plus :func:`~tether.game.field_lp.vortex_radius` (or, above ``vt/vo = 1/√2``, where
    that is negative, :func:`~tether.game.field_lp.aligned_radius`)."""
    r = vortex_radius(kern.lss, kern.vt, kern.vo)
    return kern.lss + (r if r > 0 else aligned_radius(kern.lss, kern.vt, kern.vo))


def _along_passages(env, pts: np.ndarray, clear: np.ndarray, need: float, n_a: int
                    ) -> np.ndarray:
    """Per vertex, the orientation bins (n, n_a) within :data:`ALONG` of the passage it lies
    in, both ways: all True where the space across it (the clearance plus the free distance
    straight away from the nearest wall) is at least ``2·need`` (no passage)."""
    near = shapely.get_coordinates(shapely.shortest_line(shapely.points(pts),
                                                         env.polygon.boundary)).reshape(-1, 2, 2)
    n = near[:, 0] - near[:, 1]
    norm = np.hypot(n[:, 0], n[:, 1])
    wall = norm < 1e-12  # a wall vertex: away from the wall is the inward normal there
    if wall.any():
        off = shapely.get_coordinates(shapely.shortest_line(
            shapely.points(pts[wall]), env.polygon.buffer(-1e-6 * need).boundary)
        ).reshape(-1, 2, 2)
        n[wall] = off[:, 1] - off[:, 0]
        norm[wall] = np.hypot(n[wall, 0], n[wall, 1])
    u = n / np.maximum(norm, 1e-300)[:, None]
    a = pts + u * (1e-6 * need)
    b = pts + u * (2 * need)
    hit = shapely.intersection(shapely.linestrings(np.stack([a, b], axis=1)),
                               env.polygon.boundary)
    far = np.where(shapely.is_empty(hit), np.inf, shapely.distance(shapely.points(pts), hit))
    passage = clear + far < 2 * need
    tangent = np.arctan2(u[:, 0], -u[:, 1])  # u turned by −90°
    ang = np.arange(n_a) * (_TAU / n_a)
    off = np.abs(np.mod(ang[None, :] - tangent[:, None] + math.pi / 2, math.pi) - math.pi / 2)
    return np.where(passage[:, None], off <= ALONG, True)


def _clamp(a: np.ndarray, lo: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The angles ``a`` (radians) moved into the arcs ``[lo + m, lo + w − m]``,
    ``m = min(RUN_MARGIN, w/4)``, to the nearer end where outside."""
    m = np.minimum(RUN_MARGIN, w / 4)
    rel = np.mod(a - lo, _TAU)
    inside = (rel >= m) & (rel <= w - m)
    d_lo = np.abs(np.mod(rel - m + math.pi, _TAU) - math.pi)
    d_hi = np.abs(np.mod(rel - (w - m) + math.pi, _TAU) - math.pi)
    return np.where(inside, a, lo + np.where(d_lo <= d_hi, m, w - m))


def _passages(vertices: np.ndarray, tri: np.ndarray, z: np.ndarray
              ) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per connected component (by mesh edges) of the subgraph on ``vertices``: its vertices
    in breadth-first order from the one where ``|z|`` is largest, and the predecessors
    (per mesh vertex; -1 for that first one)."""
    if not len(vertices):
        return []
    n = len(z)
    inside = np.zeros(n, bool)
    inside[vertices] = True
    e = _edges(tri)
    e = e[inside[e[:, 0]] & inside[e[:, 1]]]
    g = sparse.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n)).tocsr()
    _, label = connected_components(g, directed=False)
    out = []
    for q in np.unique(label[vertices]):
        comp = vertices[label[vertices] == q]
        seed = int(comp[np.argmax(np.abs(z[comp]))])
        order, pred = breadth_first_order(g, seed, directed=False)
        out.append((order, np.where(pred < 0, -1, pred)))
    return out
