"""Timed target tracks: a person's positions ``(t, x, y)`` as recorded or simulated, replayed
with their own timing (:class:`Track`), read from and written to files (:func:`read_track`,
:func:`write_track`).

Formats (``docs/tracks.md``), chosen by the suffix, else by the content:

* CSV (``.csv``, ``.txt``): a header row naming the columns, then one sample a row; the columns
  ``t,x,y`` by default, others by ``columns=("stamp", "px", "py")``; lines starting with ``#``
  are comments.
* JSON (``.json``): an object ``{"t": [...], "xy": [[x, y], ...]}`` (optional ``"name"``,
  ``"meta"``), or a list of objects ``[{"t": ..., "x": ..., "y": ...}, ...]`` (keys chosen by
  ``columns`` like CSV's columns).
* ROS bags (a rosbag2 folder, its ``.db3``/``.mcap`` file, or a ROS 1 ``.bag``):
  :mod:`tether.io.bags`.

Times in seconds, positions in map units; a track in another frame than the map's is the
user's to transform (a bag's ``frame_id`` is kept in ``meta``).
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tether.errors import InvalidTrackError

__all__ = ["COLUMNS", "CSV_SUFFIXES", "JSON_SUFFIXES", "Track", "read_track", "write_track"]

#: The default column names (CSV header, JSON keys): time (s), x and y (map units).
COLUMNS = ("t", "x", "y")
#: Suffixes read as CSV.
CSV_SUFFIXES = (".csv", ".txt")
#: Suffixes read as JSON.
JSON_SUFFIXES = (".json",)


@dataclass(frozen=True, eq=False)
class Track:
    """A target's timed positions: ``t`` (shape (n,), seconds, strictly increasing) and ``xy``
    (shape (n, 2), map units, in the map's frame). Between samples the position is linear in
    time; before the first sample it is the first, after the last the last.

    Examples
    --------
    >>> from tether.io.tracks import Track
    >>> tr = Track([0.0, 2.0, 4.0], [(0, 0), (1, 0), (1, 1)])
    >>> tr.duration, tr.position(1.0).tolist(), tr.velocity(3.0).tolist()
    (4.0, [0.5, 0.0], [0.0, 0.5])
    >>> round(tr.max_speed, 3)
    0.5
    """

    t: np.ndarray
    xy: np.ndarray
    name: str = ""
    meta: dict = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=float).reshape(-1)
        xy = np.asarray(self.xy, dtype=float)
        if xy.ndim != 2 or xy.shape[1:] != (2,) or len(xy) != len(t):
            raise InvalidTrackError(
                f"track: need as many (x, y) pairs as times, got {len(t)} times and "
                f"positions of shape {xy.shape}")
        if len(t) < 1:
            raise InvalidTrackError("track: no samples")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(xy))):
            raise InvalidTrackError("track: times and positions must be finite numbers")
        if len(t) > 1 and not np.all(np.diff(t) > 0):
            k = int(np.argmin(np.diff(t) > 0)) + 1
            raise InvalidTrackError(
                f"track: times must increase strictly (sample {k}: t={t[k]!r} after "
                f"t={t[k - 1]!r})")
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "xy", xy)

    def __len__(self) -> int:
        return len(self.t)

    @property
    def start(self) -> float:
        """Time of the first sample, s."""
        return float(self.t[0])

    @property
    def duration(self) -> float:
        """Time from the first sample to the last, s."""
        return float(self.t[-1] - self.t[0])

    def speeds(self) -> np.ndarray:
        """Speed on each segment between samples (shape (n-1,)), map units/s."""
        return np.hypot(*np.diff(self.xy, axis=0).T) / np.diff(self.t)

    @property
    def max_speed(self) -> float:
        """Largest segment speed, map units/s (0 for one sample)."""
        return float(self.speeds().max()) if len(self.t) > 1 else 0.0

    def position(self, t: float) -> np.ndarray:
        """Position at time ``t`` (s), linear between samples, held before and after."""
        return np.array([np.interp(t, self.t, self.xy[:, 0]),
                         np.interp(t, self.t, self.xy[:, 1])])

    def velocity(self, t: float) -> np.ndarray:
        """Velocity (map units/s) of the segment that holds ``t`` (zero outside the track;
        at a sample, the segment that starts there)."""
        if len(self.t) < 2 or t < self.t[0] or t >= self.t[-1]:
            return np.zeros(2)
        k = int(np.searchsorted(self.t, t, side="right")) - 1
        return (self.xy[k + 1] - self.xy[k]) / (self.t[k + 1] - self.t[k])

    def shifted(self, dt: float) -> Track:
        """The same track with every time moved by ``dt`` s."""
        return Track(self.t + dt, self.xy, self.name, dict(self.meta))


# ------------------------------------------------------------------------------ reading
def read_track(path: str | Path, *, topic: str | None = None,
               columns: Sequence[str] | None = None) -> Track:
    r"""The track in ``path``: CSV, JSON or a ROS bag (see the module docstring).

    Parameters
    ----------
    path : str or Path
        A ``.csv``/``.txt`` or ``.json`` file, a rosbag2 folder (or its ``.db3``/``.mcap``
        file), or a ROS 1 ``.bag``; another suffix is read as JSON when the text starts with
        ``{`` or ``[``, else as CSV.
    topic : str, optional
        The bag's topic (bags only; the default is the one topic of a supported type).
    columns : (str, str, str), optional
        Names of the time, x and y columns (CSV header, keys of JSON objects); default
        :data:`COLUMNS`.

    Returns
    -------
    Track
        Named after the file's stem.

    Raises
    ------
    InvalidTrackError
        One line naming the file and what is wrong: missing, binary or truncated, a missing
        column, a value that is not a finite number, times not increasing strictly, no samples,
        a bad topic or message type, or ``topic``/``columns`` given for a format without them.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from tether.io.tracks import read_track
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "walk.csv"
    >>> _ = f.write_text("stamp,px,py\n0,1,1\n2,1,2\n")
    >>> tr = read_track(f, columns=("stamp", "px", "py"))
    >>> tr.name, tr.position(1.0).tolist()
    ('walk', [1.0, 1.5])
    >>> read_track(f)
    Traceback (most recent call last):
    ...
    tether.errors.InvalidTrackError: ...walk.csv: no column 't' (the header has stamp, px, py)
    """
    from tether.io import bags

    p = Path(path)
    if p.is_dir() or p.suffix.lower() in bags.BAG_SUFFIXES:
        if columns is not None:
            raise InvalidTrackError(f"{p}: columns apply to CSV and JSON tracks, not to bags")
        return Track(*bags.bag_samples(p, topic=topic))
    if topic is not None:
        raise InvalidTrackError(f"{p}: a topic applies to ROS bags only")
    cols = _columns(columns)
    text = _text(p)
    suffix = p.suffix.lower()
    is_json = suffix in JSON_SUFFIXES or (
        suffix not in CSV_SUFFIXES and text.lstrip()[:1] in ("{", "["))
    return _json_track(p, text, cols) if is_json else _csv_track(p, text, cols)


def _columns(columns: Sequence[str] | None) -> tuple[str, str, str]:
    if columns is None:
        return COLUMNS
    cols = tuple(columns)
    if len(cols) != 3 or not all(isinstance(c, str) and c for c in cols):
        raise InvalidTrackError(f"columns must be three names (time, x, y), got {columns!r}")
    if len(set(cols)) != 3:
        raise InvalidTrackError(f"columns must be three different names, got {cols!r}")
    return cols  # type: ignore[return-value]


def _text(p: Path) -> str:
    try:
        data = p.read_bytes()
    except FileNotFoundError:
        raise InvalidTrackError(f"{p}: no such track file") from None
    except OSError as exc:
        raise InvalidTrackError(f"{p}: cannot read the track ({exc.strerror or exc})") from None
    if b"\x00" in data:
        raise InvalidTrackError(f"{p}: not a text file (CSV or JSON track)")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InvalidTrackError(f"{p}: not UTF-8 text (byte {exc.start})") from None


def _number(p: Path, where: str, name: str, value: object) -> float:
    """``value`` as a finite float, or one line naming the file, the place and the column."""
    if isinstance(value, bool) or not isinstance(value, int | float | str):
        raise InvalidTrackError(f"{p}: {where}: {name} is not a number ({value!r})")
    try:
        v = float(value)
    except ValueError:
        raise InvalidTrackError(f"{p}: {where}: {name} is not a number ({value!r})") from None
    if not math.isfinite(v):
        raise InvalidTrackError(f"{p}: {where}: {name} is not a finite number ({value!r})")
    return v


def _csv_track(p: Path, text: str, cols: tuple[str, str, str]) -> Track:
    rows = [(k, row) for k, row in enumerate(csv.reader(io.StringIO(text)), start=1)
            if row and any(c.strip() for c in row) and not row[0].lstrip().startswith("#")]
    if not rows:
        raise InvalidTrackError(f"{p}: empty track (no header row, no samples)")
    header = [c.strip() for c in rows[0][1]]
    missing = [c for c in cols if c not in header]
    if missing:
        raise InvalidTrackError(f"{p}: no column {missing[0]!r} (the header has "
                                f"{', '.join(header)})")
    idx = [header.index(c) for c in cols]
    values = []
    where = []
    for line, row in rows[1:]:
        if len(row) < len(header):
            raise InvalidTrackError(f"{p}: line {line}: {len(row)} fields, the header has "
                                    f"{len(header)} (a truncated file?)")
        values.append([_number(p, f"line {line}", c, row[i].strip())
                       for c, i in zip(cols, idx, strict=True)])
        where.append(f"line {line}")
    return _build(p, np.array(values, dtype=float).reshape(-1, 3), where)


def _json_track(p: Path, text: str, cols: tuple[str, str, str]) -> Track:
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InvalidTrackError(f"{p}: bad JSON at line {exc.lineno} column {exc.colno}: "
                                f"{exc.msg}") from None
    name, meta = p.stem, {}
    if isinstance(data, dict):
        for key in ("t", "xy"):
            if key not in data:
                raise InvalidTrackError(f"{p}: no {key!r} in the JSON object (expected "
                                        '{"t": [...], "xy": [[x, y], ...]} or a list of '
                                        f"{{{cols[0]!r}, {cols[1]!r}, {cols[2]!r}}} objects)")
        t, xy = data["t"], data["xy"]
        if not isinstance(t, list) or not isinstance(xy, list) or len(t) != len(xy):
            raise InvalidTrackError(f"{p}: 't' and 'xy' must be lists of the same length")
        values = []
        for k, (tk, pk) in enumerate(zip(t, xy, strict=True)):
            if not isinstance(pk, list) or len(pk) != 2:
                raise InvalidTrackError(f"{p}: xy[{k}] is not an [x, y] pair ({pk!r})")
            values.append([_number(p, f"sample {k}", "t", tk),
                           _number(p, f"sample {k}", "x", pk[0]),
                           _number(p, f"sample {k}", "y", pk[1])])
        name = str(data.get("name") or name)
        meta = data.get("meta") if isinstance(data.get("meta"), dict) else {}
    elif isinstance(data, list):
        values = []
        for k, obj in enumerate(data):
            if not isinstance(obj, dict):
                raise InvalidTrackError(f"{p}: item {k} is not an object with keys "
                                        f"{', '.join(cols)}")
            missing = [c for c in cols if c not in obj]
            if missing:
                raise InvalidTrackError(f"{p}: item {k} has no {missing[0]!r}")
            values.append([_number(p, f"item {k}", c, obj[c]) for c in cols])
    else:
        raise InvalidTrackError(f"{p}: a JSON track is an object with 't' and 'xy' or a list "
                                "of objects")
    where = [f"sample {k}" if isinstance(data, dict) else f"item {k}"
             for k in range(len(values))]
    return _build(p, np.array(values, dtype=float).reshape(-1, 3), where, name, meta)


def _build(p: Path, txy: np.ndarray, where: Sequence[str], name: str | None = None,
           meta: dict | None = None) -> Track:
    """The track of rows ``(t, x, y)``; empty or unordered input named by ``where[k]``."""
    if len(txy) == 0:
        raise InvalidTrackError(f"{p}: empty track (no samples)")
    dt = np.diff(txy[:, 0])
    if np.any(dt <= 0):
        k = int(np.argmax(dt <= 0)) + 1
        raise InvalidTrackError(
            f"{p}: {where[k]}: times must increase strictly (t={txy[k, 0]!r} after "
            f"t={txy[k - 1, 0]!r})")
    return Track(txy[:, 0], txy[:, 1:], p.stem if name is None else name, dict(meta or {}))


# ------------------------------------------------------------------------------ writing
def write_track(track: Track, path: str | Path) -> None:
    """Write ``track`` whole or not at all: ``.csv`` (header ``t,x,y``, one sample a row) or
    ``.json`` (``{"name", "t", "xy", "meta"}``; ``meta`` when it is JSON-ready). Numbers are
    written in full (``repr``), so reading the file back gives the same floats.

    Raises
    ------
    OutputPathError
        If the suffix is neither, or the path cannot be written.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from tether.io.tracks import Track, read_track, write_track
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "walk.json"
    >>> write_track(Track([0.0, 0.1], [(0.5, 1.0), (0.6, 1.0)], "walk"), f)
    >>> read_track(f).xy.tolist()
    [[0.5, 1.0], [0.6, 1.0]]
    """
    from tether._util.files import atomic_output, check_output_path

    p = check_output_path(path, (".csv", ".json"))
    if p.suffix.lower() == ".csv":
        rows = ["t,x,y", *(f"{t!r},{x!r},{y!r}" for t, (x, y) in
                           zip(track.t.tolist(), track.xy.tolist(), strict=True))]
        text = "\n".join(rows) + "\n"
    else:
        doc = {"name": track.name, "t": track.t.tolist(), "xy": track.xy.tolist()}
        try:
            doc["meta"] = json.loads(json.dumps(track.meta, allow_nan=False))
        except (TypeError, ValueError):
            pass  # meta that JSON cannot hold is left out
        text = json.dumps(doc) + "\n"
    with atomic_output(p) as tmp:
        tmp.write_text(text)
