"""ROS occupancy maps (``map_server`` YAML + PGM/PNG) read as polygons with holes, and back.

A ROS map is an image plus a YAML file::

    image: office.pgm          # relative to the YAML file
    resolution: 0.05           # metres per cell
    origin: [-1.0, -2.0, 0.0]  # pose (x, y, yaw) of the lower-left cell's corner in the map frame
    negate: 0
    occupied_thresh: 0.65
    free_thresh: 0.196
    mode: trinary              # optional: trinary (default), scale or raw

A cell is *free* when its occupancy probability is below ``free_thresh`` (probability
``(255 - v) / 255`` for a pixel value ``v``, or ``v / 255`` with ``negate: 1``; in ``raw`` mode
``v / 100``, values above 100 unknown). Occupied and unknown cells are both obstacles: tether
never plans through space nobody has seen.

:func:`read_ros_map` turns the free cells into an :class:`~tether.environment.Environment`:

1. keep the 4-connected free component that contains a seed point (default: the largest);
2. close *diagonal pinches* (two free cells meeting only at a corner, across two obstacle cells):
   the free cell of the pinch becomes an obstacle, so that no ring touches itself or another ring
   at a point; repeat until none is left, re-taking the component each time;
3. vectorize exactly in integer cell coordinates: each row's runs of free cells become boxes,
   merged by ``shapely.union_all`` (GEOS's cascaded union; no hand-written contour tracing);
4. drop holes smaller than ``min_hole_area`` (default four cells) and simplify with a
   topology-preserving Douglas-Peucker at ``simplify`` metres (default one cell), halving the
   tolerance until the result is a valid map;
5. map cell coordinates to metres in the map frame: scale by the resolution, rotate by the
   origin's yaw, translate by the origin.

:func:`rasterize` goes the other way (cells whose centre lies in the free space are free) and
:meth:`OccupancyGrid.save` writes a ``map_server`` PGM + YAML pair.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Polygon

from tether.environment import Environment
from tether.errors import InvalidMapError, InvalidParameterError

__all__ = [
    "FREE",
    "Conversion",
    "OCCUPIED",
    "UNKNOWN",
    "OccupancyGrid",
    "close_pinches",
    "free_component",
    "rasterize",
    "read_grid",
    "read_ros_map",
    "vectorize",
]

#: Cell states of an :class:`OccupancyGrid` (as in ``nav_msgs/OccupancyGrid``).
FREE, OCCUPIED, UNKNOWN = 0, 100, -1

#: Pixel values written by :meth:`OccupancyGrid.save` (those of ``map_saver``).
_PGM_VALUE = {FREE: 254, OCCUPIED: 0, UNKNOWN: 205}

_YAML_KEYS = {"image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh",
              "mode"}
_MODES = ("trinary", "scale", "raw")

#: Default smallest hole kept, in cells (area ``4 * resolution**2``).
DEFAULT_MIN_HOLE_CELLS = 4.0


# ---------------------------------------------------------------------- the grid
@dataclass(frozen=True, eq=False)
class OccupancyGrid:
    """A 2-D occupancy grid in the ``nav_msgs/OccupancyGrid`` convention.

    Parameters
    ----------
    cells : ndarray of int8, shape (rows, cols)
        ``FREE`` (0), ``OCCUPIED`` (100) or ``UNKNOWN`` (-1). Row 0 is the *bottom* row
        (smallest y), as in ROS messages; images store it last.
    resolution : float
        Cell size, metres.
    origin : tuple of float
        ``(x, y, yaw)``: the map-frame pose of the lower-left corner of cell ``(0, 0)``;
        metres, radians.
    name : str
        A label for reports.
    """

    cells: np.ndarray
    resolution: float
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    name: str = ""
    source: str = field(default="", repr=False)

    def __post_init__(self) -> None:
        cells = np.asarray(self.cells, dtype=np.int8)
        if cells.ndim != 2 or min(cells.shape) < 1:
            raise InvalidMapError(f"{self.where}: the grid must be a non-empty 2-D array")
        object.__setattr__(self, "cells", cells)
        res = float(self.resolution)
        if not (math.isfinite(res) and res > 0):
            raise InvalidMapError(f"{self.where}: resolution must be a positive number, "
                                  f"got {self.resolution!r}")
        object.__setattr__(self, "resolution", res)
        origin = tuple(float(v) for v in self.origin)
        if len(origin) != 3 or not all(math.isfinite(v) for v in origin):
            raise InvalidMapError(f"{self.where}: origin must be three finite numbers "
                                  "[x, y, yaw]")
        object.__setattr__(self, "origin", origin)

    @property
    def where(self) -> str:
        """The grid's name in messages: its file, its name, or "occupancy grid"."""
        return self.source or self.name or "occupancy grid"

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, columns)`` of cells."""
        return self.cells.shape  # type: ignore[return-value]

    @property
    def free(self) -> np.ndarray:
        """Boolean mask of free cells, shape (rows, cols), row 0 at the bottom."""
        return self.cells == FREE

    # -------------------------------------------------------------- frames
    def to_world(self, uv: Any) -> np.ndarray:
        """Cell coordinates ``(u, v)`` (column, row from the bottom, in cells) to metres."""
        uv = np.asarray(uv, dtype=float)
        x0, y0, yaw = self.origin
        c, s = math.cos(yaw), math.sin(yaw)
        u = uv[..., 0] * self.resolution
        v = uv[..., 1] * self.resolution
        return np.stack((x0 + c * u - s * v, y0 + s * u + c * v), axis=-1)

    def to_cells(self, xy: Any) -> np.ndarray:
        """Metres in the map frame to cell coordinates ``(u, v)`` (floats, in cells)."""
        xy = np.asarray(xy, dtype=float)
        x0, y0, yaw = self.origin
        c, s = math.cos(yaw), math.sin(yaw)
        dx, dy = xy[..., 0] - x0, xy[..., 1] - y0
        return np.stack(((c * dx + s * dy) / self.resolution,
                         (-s * dx + c * dy) / self.resolution), axis=-1)

    def cell_center(self, row: int, col: int) -> tuple[float, float]:
        """Map-frame centre of cell ``(row, col)`` (row 0 at the bottom), metres."""
        x, y = self.to_world([col + 0.5, row + 0.5])
        return float(x), float(y)

    # -------------------------------------------------------------- conversion
    def to_environment(self, seed_point: Any = None, simplify: float | None = None,
                       min_hole_area: float | None = None) -> Environment:
        """The free space as a polygon with holes; see :func:`read_ros_map`."""
        return self.convert(seed_point, simplify, min_hole_area).env

    def convert(self, seed_point: Any = None, simplify: float | None = None,
                min_hole_area: float | None = None) -> Conversion:
        """:meth:`to_environment` with a record of what the conversion kept and dropped."""
        mask = free_component(self, seed_point)
        poly = vectorize(mask)
        res = self.resolution
        simplify = res if simplify is None else _nonneg(simplify, "simplify")
        min_hole = (DEFAULT_MIN_HOLE_CELLS * res * res if min_hole_area is None
                    else _nonneg(min_hole_area, "min_hole_area"))
        kept = _drop_small_holes(poly, min_hole / (res * res))
        env, tol = _to_environment(self, kept, simplify / res)
        return Conversion(env, self.shape, int(self.free.sum()), int(mask.sum()),
                          len(poly.interiors) - len(kept.interiors), min_hole, tol * res,
                          len(poly.exterior.coords) - 1
                          + sum(len(r.coords) - 1 for r in poly.interiors))

    # -------------------------------------------------------------- output
    def image(self) -> np.ndarray:
        """The ``map_saver`` image: uint8, row 0 at the top, 254 free, 0 occupied, 205 unknown."""
        img = np.full(self.cells.shape, _PGM_VALUE[UNKNOWN], dtype=np.uint8)
        img[self.cells == FREE] = _PGM_VALUE[FREE]
        img[self.cells == OCCUPIED] = _PGM_VALUE[OCCUPIED]
        return np.flipud(img)

    def save(self, yaml_path: str | Path) -> Path:
        """Write ``<stem>.pgm`` and the YAML file ``yaml_path`` (trinary, ``map_saver`` values).

        Returns the path of the image written.
        """
        import yaml
        from PIL import Image

        from tether._util.files import atomic_output

        yp = Path(yaml_path)
        img_path = yp.with_suffix(".pgm")
        with atomic_output(img_path) as tmp:
            Image.fromarray(self.image(), mode="L").save(tmp, format="PPM")
        meta = {"image": img_path.name, "mode": "trinary", "resolution": self.resolution,
                "origin": list(self.origin), "negate": 0, "occupied_thresh": 0.65,
                "free_thresh": 0.196}
        with atomic_output(yp) as tmp:
            Path(tmp).write_text(yaml.safe_dump(meta, sort_keys=False))
        return img_path


@dataclass(frozen=True)
class Conversion:
    """What :meth:`OccupancyGrid.convert` made of a grid.

    ``env`` the map; ``shape`` the grid's (rows, cols); ``free_cells`` all free cells and
    ``kept_cells`` those of the component kept (after closing pinches); ``dropped_holes`` holes
    under ``min_hole_area`` (square metres) made free; ``simplify`` the tolerance finally used
    (metres; lower than asked when the asked one gave an invalid map); ``exact_vertices`` the
    vertex count before simplification.
    """

    env: Environment
    shape: tuple[int, int]
    free_cells: int
    kept_cells: int
    dropped_holes: int
    min_hole_area: float
    simplify: float
    exact_vertices: int

    def summary(self) -> str:
        """One line for the CLI."""
        rows, cols = self.shape
        return (f"from {cols} x {rows} cells: kept {self.kept_cells} of {self.free_cells} free "
                f"cells (one component), dropped {self.dropped_holes} holes under "
                f"{self.min_hole_area:.4g} m², simplified {self.exact_vertices} vertices at "
                f"{self.simplify:.4g} m")

    def to_dict(self) -> dict:
        """What ``tether convert`` reports: the grid, the cells kept and the polygon's size."""
        return {"map": self.env.name, "shape": list(self.shape), "free_cells": self.free_cells,
                "kept_cells": self.kept_cells, "dropped_holes": self.dropped_holes,
                "min_hole_area": self.min_hole_area, "simplify": self.simplify,
                "exact_vertices": self.exact_vertices, "vertices": self.env.n,
                "holes": len(self.env.holes)}


def _nonneg(value: Any, what: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{what} must be a number, got {value!r}") from None
    if not (math.isfinite(v) and v >= 0):
        raise InvalidParameterError(f"{what} must be a finite number >= 0, got {value!r}")
    return v


# ---------------------------------------------------------------------- reading
def _yaml_number(meta: dict, key: str, where: str, default: float | None = None) -> float:
    if key not in meta:
        if default is None:
            raise InvalidMapError(f"{where}: missing key {key!r}")
        return default
    val = meta[key]
    if isinstance(val, bool) or not isinstance(val, int | float) or not math.isfinite(val):
        raise InvalidMapError(f"{where}: {key!r} must be a number, got {val!r}")
    return float(val)


def _read_meta(yaml_path: Path) -> dict:
    import yaml

    where = str(yaml_path)
    try:
        text = yaml_path.read_text()
    except OSError as exc:
        raise InvalidMapError(f"{where}: cannot read ({exc.strerror})") from None
    try:
        meta = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        raise InvalidMapError(f"{where}: malformed YAML{at}") from None
    if not isinstance(meta, dict):
        raise InvalidMapError(f"{where}: expected a ROS map_server YAML mapping")
    unknown = set(map(str, meta)) - _YAML_KEYS
    if unknown:
        raise InvalidMapError(f"{where}: unknown key(s) {', '.join(sorted(unknown))}; "
                              f"expected {', '.join(sorted(_YAML_KEYS))}")
    return meta


def _classify(pixels: np.ndarray, mode: str, negate: bool, occ: float, free: float
              ) -> np.ndarray:
    """Cell states from pixel values (image rows, row 0 at the top)."""
    v = pixels.astype(float)
    cells = np.full(pixels.shape, UNKNOWN, dtype=np.int8)
    if mode == "raw":  # values are occupancy percentages; above 100 is unknown
        known = v <= 100
        p = np.where(known, v / 100.0, 0.5)
        cells[known & (p > occ)] = OCCUPIED
        cells[known & (p < free)] = FREE
        return cells
    p = v / 255.0 if negate else (255.0 - v) / 255.0
    cells[p > occ] = OCCUPIED
    cells[p < free] = FREE
    return cells


def read_grid(yaml_path: str | Path) -> OccupancyGrid:
    """Read a ``map_server`` map (YAML + image) into an :class:`OccupancyGrid`.

    Raises
    ------
    InvalidMapError
        If the YAML is malformed, has unknown or missing keys or bad values, or the image is
        missing or unreadable. Messages name the file and the key.
    """
    from PIL import Image, UnidentifiedImageError

    yp = Path(yaml_path)
    where = str(yaml_path)
    meta = _read_meta(yp)
    if not isinstance(meta.get("image"), str) or not meta["image"]:
        raise InvalidMapError(f"{where}: 'image' must name the map image (.pgm or .png)")
    res = _yaml_number(meta, "resolution", where)
    if res <= 0:
        raise InvalidMapError(f"{where}: 'resolution' must be > 0, got {res:g}")
    origin = meta.get("origin", [0.0, 0.0, 0.0])
    if (not isinstance(origin, list) or len(origin) not in (2, 3)
            or not all(isinstance(v, int | float) and not isinstance(v, bool)
                       and math.isfinite(v) for v in origin)):
        raise InvalidMapError(f"{where}: 'origin' must be [x, y, yaw] numbers, got {origin!r}")
    origin = [float(v) for v in origin] + [0.0] * (3 - len(origin))
    if isinstance(meta.get("negate"), bool):  # ``negate: true`` is read as 1
        meta["negate"] = int(meta["negate"])
    negate = _yaml_number(meta, "negate", where, 0.0)
    if negate not in (0.0, 1.0):
        raise InvalidMapError(f"{where}: 'negate' must be 0 or 1, got {meta['negate']!r}")
    occ = _yaml_number(meta, "occupied_thresh", where, 0.65)
    free = _yaml_number(meta, "free_thresh", where, 0.196)
    if not 0 <= free <= occ <= 1:
        raise InvalidMapError(f"{where}: need 0 <= free_thresh <= occupied_thresh <= 1, got "
                              f"free_thresh {free:g}, occupied_thresh {occ:g}")
    mode = meta.get("mode", "trinary")
    if mode not in _MODES:
        raise InvalidMapError(f"{where}: 'mode' must be one of {', '.join(_MODES)}, "
                              f"got {mode!r}")
    img_path = yp.parent / meta["image"]
    try:
        with Image.open(img_path) as im:
            im = im.convert("LA") if im.mode in ("LA", "RGBA", "PA") else im.convert("L")
            pixels = np.asarray(im)[..., 0] if im.mode == "LA" else np.asarray(im)
    except FileNotFoundError:
        raise InvalidMapError(f"{where}: image {str(img_path)!r} not found") from None
    except (OSError, UnidentifiedImageError, Image.DecompressionBombError) as exc:
        raise InvalidMapError(f"{where}: cannot read image {str(img_path)!r} ({exc})") from None
    cells = np.flipud(_classify(pixels, mode, bool(negate), occ, free))
    return OccupancyGrid(cells, res, tuple(origin), name=yp.stem, source=where)


def read_ros_map(yaml_path: str | Path, seed_point: Any = None, simplify: float | None = None,
                 min_hole_area: float | None = None) -> Environment:
    """Read a ROS ``map_server`` map as an :class:`Environment` in metres in the map frame.

    Parameters
    ----------
    yaml_path : path
        The map's YAML file; its ``image`` is read relative to it.
    seed_point : (x, y), optional
        A point of the free space wanted, metres in the map frame. The free space is the
        4-connected component of free cells containing it; default: the largest component.
    simplify : float, optional
        Douglas-Peucker tolerance, metres (topology preserving). Default: one cell. ``0`` keeps
        the cell staircase (collinear vertices removed).
    min_hole_area : float, optional
        Holes (obstacles inside the free space) smaller than this, square metres, are dropped
        (become free). Default: four cells.

    Raises
    ------
    InvalidMapError
        If the files are malformed, no cell is free, or the seed is not in a free cell (the
        message gives the seed's coordinates and its cell).
    InvalidParameterError
        If ``simplify`` or ``min_hole_area`` is negative or not a number.
    """
    return read_grid(yaml_path).to_environment(seed_point, simplify, min_hole_area)


# ---------------------------------------------------------------------- components and pinches
def _label(mask: np.ndarray) -> tuple[np.ndarray, int]:
    from scipy import ndimage

    return ndimage.label(mask)  # 4-connectivity (the default structure)


def _component(mask: np.ndarray, seed_rc: tuple[int, int] | None) -> np.ndarray:
    labels, n = _label(mask)
    if n == 0:
        return np.zeros_like(mask)
    if seed_rc is not None:
        k = labels[seed_rc]
        if k == 0:
            return np.zeros_like(mask)
    else:
        sizes = np.bincount(labels.ravel(), minlength=n + 1)
        sizes[0] = 0
        k = int(np.argmax(sizes))
    return labels == k


def close_pinches(mask: np.ndarray) -> np.ndarray:
    """Remove diagonal pinches: in every 2x2 block where two free cells meet only at a corner
    (the other two cells are obstacles), the free cell on the left becomes an obstacle.

    Repeats until no pinch is left; returns a new mask (row 0 at the bottom). Free space only
    shrinks, by at most one cell per pinch.
    """
    m = np.pad(np.asarray(mask, dtype=bool), 1)
    while True:
        a, b = m[:-1, :-1], m[:-1, 1:]  # row r:   left, right
        c, d = m[1:, :-1], m[1:, 1:]    # row r+1: left, right
        main = a & d & ~b & ~c          # free at (r, j) and (r+1, j+1)
        anti = b & c & ~a & ~d          # free at (r, j+1) and (r+1, j)
        if not (main.any() or anti.any()):
            return m[1:-1, 1:-1].copy()
        rows, cols = np.nonzero(main)
        m[rows, cols] = False
        rows, cols = np.nonzero(anti)
        m[rows + 1, cols] = False


def _seed_cell(grid: OccupancyGrid, seed_point: Any) -> tuple[int, int]:
    try:
        sx, sy = (float(v) for v in seed_point)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"seed point must be (x, y), got {seed_point!r}") from None
    u, v = grid.to_cells([sx, sy])
    col, row = int(math.floor(u)), int(math.floor(v))
    rows, cols = grid.shape
    if not (0 <= row < rows and 0 <= col < cols):
        raise InvalidMapError(f"{grid.where}: seed point ({sx:g}, {sy:g}) lies outside the map")
    if grid.cells[row, col] != FREE:
        state = "occupied" if grid.cells[row, col] == OCCUPIED else "unknown"
        raise InvalidMapError(f"{grid.where}: seed point ({sx:g}, {sy:g}) lies in an {state} "
                              f"cell (row {rows - 1 - row}, column {col} of the image)")
    return row, col


def free_component(grid: OccupancyGrid, seed_point: Any = None) -> np.ndarray:
    """Boolean mask (row 0 at the bottom) of the free component used as the free space.

    The 4-connected free component containing ``seed_point`` (metres) or the largest one,
    with diagonal pinches closed (:func:`close_pinches`) and the component re-taken until stable.

    Raises
    ------
    InvalidMapError
        If no cell is free, or the seed is outside the map, not in a free cell, or in a component
        that the pinch closing removes entirely.
    """
    seed_rc = None if seed_point is None else _seed_cell(grid, seed_point)
    mask = grid.free
    if not mask.any():
        raise InvalidMapError(f"{grid.where}: no free cell (check negate and free_thresh)")
    while True:
        comp = _component(mask, seed_rc)
        closed = close_pinches(comp)
        if not closed.any() or (seed_rc is not None and not closed[seed_rc]):
            at = "" if seed_point is None else f" around the seed ({seed_point[0]:g}, " \
                                               f"{seed_point[1]:g})"
            raise InvalidMapError(f"{grid.where}: the free space{at} vanishes when diagonal "
                                  "pinches are closed (a single-cell-wide diagonal passage)")
        if np.array_equal(closed, comp):
            return comp
        mask = closed


# ---------------------------------------------------------------------- vectorizing
def _row_runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Runs of True along each row: ``(row, start_col, end_col_exclusive)`` arrays."""
    p = np.pad(mask.astype(np.int8), ((0, 0), (1, 1)))
    diff = np.diff(p, axis=1)
    rs, cs = np.nonzero(diff == 1)
    re, ce = np.nonzero(diff == -1)
    # nonzero scans row-major, so starts and ends pair up in order
    assert np.array_equal(rs, re)
    return rs, cs, ce


def _vertical_merge(rows: np.ndarray, c0: np.ndarray, c1: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Stack identical runs of consecutive rows into rectangles ``(c0, r0, c1, r1)``."""
    order = np.lexsort((rows, c1, c0))
    rows, c0, c1 = rows[order], c0[order], c1[order]
    new = np.ones(len(rows), dtype=bool)
    new[1:] = (c0[1:] != c0[:-1]) | (c1[1:] != c1[:-1]) | (rows[1:] != rows[:-1] + 1)
    start = np.flatnonzero(new)
    end = np.append(start[1:], len(rows)) - 1
    return c0[start], rows[start], c1[start], rows[end] + 1


def vectorize(mask: np.ndarray, method: str = "edges") -> Polygon:
    """The union of the True cells of ``mask`` (row 0 at the bottom) as one polygon, exactly,
    in cell coordinates (``x`` = column, ``y`` = row; cell ``(r, c)`` is ``[c, c+1] x [r, r+1]``).

    The mask must be one 4-connected component without diagonal pinches (see
    :func:`free_component`); then the result is a valid polygon whose rings touch nowhere.

    ``method="edges"`` (default) takes the cell edges between a kept and another cell (numpy),
    joins them into maximal straight segments and lets GEOS merge those into rings
    (``shapely.line_merge``); every boundary vertex has two edges when no pinch is left, so the
    rings close. ``method="union"`` merges the rows' runs of cells as rectangles with
    ``shapely.union_all`` (several times slower on ragged maps); it is the fallback should the
    rings not close, and the tests' cross-check.
    """
    mask = np.asarray(mask, dtype=bool)
    if method == "edges":
        poly = _vectorize_edges(mask)
        if poly is not None:
            return poly
    elif method != "union":
        raise InvalidParameterError(f"method must be 'edges' or 'union', got {method!r}")
    rows, c0, c1 = _row_runs(mask)
    x0, y0, x1, y1 = _vertical_merge(rows, c0, c1)
    geom = shapely.union_all(shapely.box(x0, y0, x1, y1))
    if geom.geom_type != "Polygon":
        raise InvalidMapError(f"the free cells form a {geom.geom_type}, not one polygon")
    return shapely.simplify(geom, 0.0)  # drop the collinear vertices of the box seams


def _edge_segments(mask: np.ndarray) -> np.ndarray:
    """Maximal straight runs of cell edges between kept and other cells: (k, 2, 2) endpoints
    ``(x, y)`` in cell coordinates."""
    m = np.pad(mask, 1)
    rows, c0, c1 = _row_runs(m[1:, :] != m[:-1, :])  # horizontal edges at y = row
    horiz = np.stack((np.column_stack((c0 - 1, rows)), np.column_stack((c1 - 1, rows))), axis=1)
    cols, r0, r1 = _row_runs((m[:, 1:] != m[:, :-1]).T)  # vertical edges at x = col
    vert = np.stack((np.column_stack((cols, r0 - 1)), np.column_stack((cols, r1 - 1))), axis=1)
    return np.concatenate((horiz, vert)).astype(float)


def _vectorize_edges(mask: np.ndarray) -> Polygon | None:
    """The polygon from the boundary edges (see :func:`vectorize`); ``None`` if they do not
    close into one outer ring and holes."""
    segs = _edge_segments(mask)
    if len(segs) == 0:
        return None
    merged = shapely.line_merge(shapely.multilinestrings(shapely.linestrings(segs)))
    lines = shapely.get_parts(merged)
    if not np.all(shapely.is_closed(lines)):
        return None
    coords, index = shapely.get_coordinates(lines, return_index=True)
    rings = shapely.linearrings(coords, indices=index)
    areas = shapely.area(shapely.polygons(rings))
    k = int(np.argmax(areas))
    poly = shapely.polygons(rings[k], np.delete(rings, k))
    poly = shapely.simplify(poly, 0.0)  # a ring's start may sit mid-edge
    if not poly.is_valid or abs(poly.area - mask.sum()) > 1e-6:
        return None
    return poly


def _drop_small_holes(poly: Polygon, min_area: float) -> Polygon:
    """``poly`` without the holes of area below ``min_area`` (same units as ``poly``)."""
    if min_area <= 0 or not poly.interiors:
        return poly
    keep = [r for r in poly.interiors if Polygon(r).area >= min_area]
    return Polygon(poly.exterior, keep)


def _simplified(poly: Polygon, tol: float) -> Polygon:
    """Topology-preserving simplification at ``tol`` (cells), halving it until valid."""
    while tol > 1e-3:
        out = shapely.simplify(poly, tol, preserve_topology=True)
        if out.geom_type == "Polygon" and out.is_valid and not out.is_empty \
                and abs(out.area - poly.area) <= 0.5 * poly.area:
            return out
        tol /= 2
    return poly


def _to_environment(grid: OccupancyGrid, poly: Polygon, tol_cells: float
                    ) -> tuple[Environment, float]:
    """Simplify in cell units, map to metres, and build the Environment (retrying finer);
    returns it with the tolerance used (cells)."""
    last: InvalidMapError | None = None
    for tol in (tol_cells, tol_cells / 2, tol_cells / 4, 0.0):
        simple = _simplified(poly, tol) if tol > 0 else poly
        rings = [np.asarray(simple.exterior.coords)[:-1]]
        rings += [np.asarray(r.coords)[:-1] for r in simple.interiors]
        rings = [np.round(grid.to_world(r), 9) for r in rings]  # float noise of the transform
        try:
            return Environment(rings[0], tuple(rings[1:]), grid.name), tol
        except InvalidMapError as exc:
            last = exc
    raise InvalidMapError(f"{grid.where}: {last}")


# ---------------------------------------------------------------------- rasterizing
def rasterize(env: Environment, resolution: float, margin: int = 1,
              origin: tuple[float, float] | None = None) -> OccupancyGrid:
    """An occupancy grid of ``env``: a cell is free when its centre lies in the free space.

    Parameters
    ----------
    env : Environment
    resolution : float
        Cell size, map units (metres).
    margin : int
        Occupied cells added around the map's bounding box on every side.
    origin : (x, y), optional
        Lower-left corner of the grid; default: the bounding box's corner minus the margin.
        Choosing it on a multiple of ``resolution`` makes axis-aligned walls at multiples of
        ``resolution`` come out exact.

    Returns
    -------
    OccupancyGrid
        Free or occupied cells (no unknown), yaw 0.
    """
    res = _nonneg(resolution, "resolution")
    if res == 0:
        raise InvalidParameterError("resolution must be > 0")
    x0, y0, x1, y1 = env.bounds
    if origin is None:
        origin = (x0 - margin * res, y0 - margin * res)
    ox, oy = float(origin[0]), float(origin[1])
    cols = int(math.ceil((x1 - ox) / res)) + margin
    rows = int(math.ceil((y1 - oy) / res)) + margin
    if rows * cols > 50_000_000:
        raise InvalidParameterError(f"resolution {res:g} gives a {rows} x {cols} grid; "
                                    "choose a coarser one")
    xs = ox + (np.arange(cols) + 0.5) * res
    ys = oy + (np.arange(rows) + 0.5) * res
    gx, gy = np.meshgrid(xs, ys)
    inside = shapely.contains_xy(env.polygon, gx, gy)
    cells = np.where(inside, FREE, OCCUPIED).astype(np.int8)
    return OccupancyGrid(cells, res, (ox, oy, 0.0), name=env.name)
