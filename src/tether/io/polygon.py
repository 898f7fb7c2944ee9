"""Polygon map files: tether's JSON form, GeoJSON and WKT, read (with messages that name the
file, line and field) and written.

tether's JSON form is ``{"name": ..., "boundary": [[x, y], ...], "holes": [[[x, y], ...], ...]}``
(rings without a closing vertex); GeoJSON is a Polygon, a Feature or a one-feature collection
(the Feature's ``properties.name`` is the map's name); WKT is a ``POLYGON``. Feature names follow
the file (see :mod:`tether.environment`).
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import shapely

from tether.environment import Environment
from tether.errors import InvalidMapError
from tether.tolerances import MAX_MAP_BYTES, MAX_VERTICES

__all__ = [
    "SUFFIXES",
    "from_dict",
    "from_geojson",
    "from_wkt",
    "read_polygon",
    "text_of",
    "to_geojson",
    "to_json",
    "to_wkt",
    "write_polygon",
]

#: The file suffixes of polygon maps.
SUFFIXES = (".json", ".geojson", ".wkt")

_JSON_KEYS = {"boundary", "holes", "name"}

#: Integer literals longer than this are rejected while parsing (coordinates are ordinary
#: numbers; Python refuses to convert integers of thousands of digits anyway).
_MAX_INT_DIGITS = 400


def _show(value: Any) -> str:
    """A short JSON-like rendering of a value for messages: ``"3"``, ``true``, ``an object``."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if value is None:
        return "null"
    if isinstance(value, dict):
        return "an object"
    if isinstance(value, list):
        return f"a list of {len(value)}"
    if isinstance(value, str):
        text = json.dumps(value)
        return text if len(text) <= 30 else text[:27] + '..."'
    return repr(value)[:30]


def _check_text(text: str, path: str) -> None:
    r"""Reject strings that cannot be printed (lone surrogates from ``\ud800`` escapes)."""
    try:
        text.encode("utf-8")
    except UnicodeEncodeError as exc:
        raise InvalidMapError(f"{path}: not valid Unicode text (character {exc.start} is a "
                              "lone surrogate)") from None


def _number(value: Any, path: str) -> float:
    """A JSON number as a finite float; booleans, strings, null... rejected with the path."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InvalidMapError(f"{path}: expected a number, got {_show(value)}")
    try:
        f = float(value)
    except OverflowError:
        raise InvalidMapError(f"{path}: number too large for a coordinate") from None
    if not math.isfinite(f):
        raise InvalidMapError(f"{path}: non-finite coordinate {_show(value)}")
    return f


def _ring_list(value: Any, path: str, *, extra_dims: bool = False) -> list[list[float]]:
    """Check a JSON ring (a list of ``[x, y]`` pairs) element by element, naming the field.

    With ``extra_dims`` (GeoJSON positions), positions may carry a third or fourth number
    (altitude, measure), which is checked and dropped.
    """
    if not isinstance(value, list):
        raise InvalidMapError(f"{path}: expected a list of [x, y] pairs, got {_show(value)}")
    if len(value) > MAX_VERTICES:
        raise InvalidMapError(f"{path}: {len(value)} vertices, more than tether takes "
                              f"({MAX_VERTICES})")
    out = []
    for i, pt in enumerate(value):
        where = f"{path}[{i}]"
        if not isinstance(pt, list):
            raise InvalidMapError(f"{where}: expected an [x, y] pair, got {_show(pt)}")
        if len(pt) != 2 and not (extra_dims and 2 <= len(pt) <= 4):
            raise InvalidMapError(f"{where}: expected an [x, y] pair, got {len(pt)} values (a "
                                  "ring is a list of [x, y] pairs)")
        out.append([_number(v, f"{where}[{k}]") for k, v in enumerate(pt)][:2])
    return out


def _rings_list(value: Any, path: str, *, extra_dims: bool = False) -> list[list[list[float]]]:
    """A JSON list of rings, checked with :func:`_ring_list`."""
    if not isinstance(value, list):
        raise InvalidMapError(f"{path}: expected a list of rings, got {_show(value)}")
    rings = [_ring_list(r, f"{path}[{k}]", extra_dims=extra_dims) for k, r in enumerate(value)]
    total = sum(len(r) for r in rings)
    if total > MAX_VERTICES:
        raise InvalidMapError(f"{path}: {total} vertices in all, more than tether takes "
                              f"({MAX_VERTICES})")
    return rings


def from_dict(data: Any, where: str = "map", name: str = "") -> Environment:
    """Build an :class:`Environment` from the JSON map form, rejecting unknown keys.

    ``name`` names the map when the data gives no name (or an empty one); ``where`` prefixes
    every message (the file's path when read from a file).

    Raises
    ------
    InvalidMapError
        If keys are missing or unknown, a value has the wrong JSON type (the message names the
        field, e.g. ``holes[0][2][1]: expected a number, got "3"``), or the geometry is invalid.
    """
    if not isinstance(data, dict):
        raise InvalidMapError(f"{where}: expected a JSON object with 'boundary' and 'holes', "
                              f"got {_show(data)}")
    unknown = set(data) - _JSON_KEYS
    if unknown:
        raise InvalidMapError(f"{where}: unknown key(s) {', '.join(sorted(map(str, unknown)))}")
    if "boundary" not in data:
        raise InvalidMapError(f"{where}: missing key 'boundary'")
    given = data.get("name", "")
    if not isinstance(given, str):
        raise InvalidMapError(f"{where}: name: expected a string, got {_show(given)}")
    _check_text(given, f"{where}: name")
    try:
        boundary = _ring_list(data["boundary"], "boundary")
        holes = _rings_list(data.get("holes", []), "holes")
        if len(boundary) + sum(map(len, holes)) > MAX_VERTICES:
            raise InvalidMapError(f"more than {MAX_VERTICES} vertices in all")
        return Environment(boundary, tuple(holes), given or name)
    except InvalidMapError as exc:
        raise InvalidMapError(f"{where}: {exc}") from None


_GEOMETRY_TYPES = {"Point", "MultiPoint", "LineString", "MultiLineString", "Polygon",
                   "MultiPolygon", "GeometryCollection"}


def from_geojson(data: Any, where: str = "map", name: str = "") -> Environment:
    """Build an :class:`Environment` from a GeoJSON Polygon, Feature or one-feature collection.

    A Feature's geometry must be a Polygon (not another Feature); positions may carry an
    altitude, which is dropped. Messages name the field (``features[0].geometry.type``).
    """
    try:
        return _from_geojson(data, "", name)
    except InvalidMapError as exc:
        raise InvalidMapError(f"{where}: {exc}") from None


def _from_geojson(data: Any, path: str, name: str) -> Environment:
    here = path or "GeoJSON"
    if not isinstance(data, dict):
        raise InvalidMapError(f"{here}: expected a GeoJSON object, got {_show(data)}")
    kind = data.get("type")
    if not isinstance(kind, str):
        raise InvalidMapError(f"{path + '.' if path else ''}type: expected a string, got "
                              f"{_show(kind)}")
    dot = path + "." if path else ""
    if kind == "FeatureCollection":
        if path:
            raise InvalidMapError(f"{here}: a FeatureCollection cannot be nested")
        feats = data.get("features")
        if not isinstance(feats, list) or len(feats) != 1:
            got = f"{len(feats)} features" if isinstance(feats, list) else _show(feats)
            raise InvalidMapError(f"{dot}features: a FeatureCollection must hold exactly one "
                                  f"feature, got {got}")
        return _from_geojson(feats[0], f"{dot}features[0]", name)
    if kind == "Feature":
        if path.endswith("geometry"):
            raise InvalidMapError(f"{here}: expected a Polygon geometry, got a Feature "
                                  "(a Feature cannot be nested in a Feature)")
        props = data.get("properties") or {}
        if not isinstance(props, dict):
            raise InvalidMapError(f"{dot}properties: expected an object or null, got "
                                  f"{_show(props)}")
        nm = props.get("name", name)
        if not isinstance(nm, str):
            raise InvalidMapError(f"{dot}properties.name: expected a string, got {_show(nm)}")
        _check_text(nm, f"{dot}properties.name")
        if "geometry" not in data or data["geometry"] is None:
            raise InvalidMapError(f"{dot}geometry: missing (a Feature needs a Polygon)")
        return _from_geojson(data["geometry"], f"{dot}geometry", nm)
    if kind != "Polygon":
        what = "geometry" if kind in _GEOMETRY_TYPES else "GeoJSON type"
        raise InvalidMapError(f"{dot}type: must be a Polygon, got the {what} {kind!r}")
    rings = _rings_list(data.get("coordinates"), f"{dot}coordinates", extra_dims=True)
    if not rings:
        raise InvalidMapError(f"{dot}coordinates: the Polygon has no rings")
    return Environment(rings[0], tuple(rings[1:]), name)


_WKT_KEYWORD = re.compile(r"\s*(SRID=\d+;\s*)?([A-Za-z]+)")


def from_wkt(text: str, where: str = "map", name: str = "") -> Environment:
    """Build an :class:`Environment` from a WKT ``POLYGON`` (Z and M values are dropped)."""
    m = _WKT_KEYWORD.match(text)
    if not m:
        start = " ".join(text.split())[:30]
        raise InvalidMapError(f"{where}: not WKT: expected POLYGON ((x y, ...)), got "
                              f"{start!r}" if start else f"{where}: the file is empty")
    keyword = m.group(2).upper()
    if m.group(1):  # EWKT's spatial reference: coordinates are taken as they are
        text = text[m.start(2):]
    if keyword != "POLYGON":
        raise InvalidMapError(f"{where}: WKT must be a POLYGON, got {keyword} (a type tether "
                              "does not take)")
    try:
        geom = shapely.from_wkt(text.strip())
    except (shapely.errors.GEOSException, ValueError) as exc:
        msg = " ".join(str(exc).split())
        msg = msg if len(msg) <= 120 else msg[:117] + "..."
        raise InvalidMapError(f"{where}: malformed WKT ({msg})") from None
    if geom is None or geom.geom_type != "Polygon" or geom.is_empty:
        kind = "empty" if geom is None or geom.is_empty else geom.geom_type
        raise InvalidMapError(f"{where}: WKT must be a non-empty POLYGON, got {kind}")
    rings = [np.asarray(geom.exterior.coords)[:, :2]]
    rings += [np.asarray(r.coords)[:, :2] for r in geom.interiors]
    if sum(map(len, rings)) > MAX_VERTICES:
        raise InvalidMapError(f"{where}: more than {MAX_VERTICES} vertices in all")
    try:
        return Environment(rings[0], tuple(rings[1:]), name)
    except InvalidMapError as exc:
        raise InvalidMapError(f"{where}: {exc}") from None


def _decode(raw: bytes, where: str, json_like: bool) -> str:
    """Decode a map file: UTF-8 (with or without BOM); UTF-16/32 with a BOM, or JSON in
    UTF-16/32 without one. Binary and other encodings are rejected with the offending byte."""
    for bom, bom_codec in ((b"\xff\xfe\x00\x00", "utf-32"), (b"\x00\x00\xfe\xff", "utf-32"),
                       (b"\xff\xfe", "utf-16"), (b"\xfe\xff", "utf-16"),
                       (b"\xef\xbb\xbf", "utf-8-sig")):
        if raw.startswith(bom):
            codec = bom_codec
            break
    else:
        codec = json.detect_encoding(raw) if json_like and b"\x00" in raw[:4] else "utf-8"
    try:
        text = raw.decode(codec)
    except UnicodeDecodeError as exc:
        byte = raw[exc.start]
        line = raw[:exc.start].count(b"\n") + 1
        if b"\x00" in raw[:4096] or _looks_binary(raw):
            raise InvalidMapError(f"{where}: a binary file, not a map (byte 0x{byte:02x} at "
                                  f"offset {exc.start})") from None
        raise InvalidMapError(f"{where}: not {codec.upper()} text (byte 0x{byte:02x} at line "
                              f"{line}, offset {exc.start}); save the map as UTF-8") from None
    if "\x00" in text:
        raise InvalidMapError(f"{where}: a binary file, not a map (NUL character at offset "
                              f"{text.index(chr(0))})")
    return text


def _looks_binary(raw: bytes) -> bool:
    head = raw[:4096]
    controls = sum(b < 9 or 13 < b < 32 for b in head)
    return controls > len(head) // 20


def _parse_int(text: str) -> int:
    if len(text) > _MAX_INT_DIGITS:
        raise InvalidMapError(f"an integer of {len(text)} digits; coordinates must be ordinary "
                              f"numbers (at most {_MAX_INT_DIGITS} digits)")
    return int(text)


def _parse_json(text: str, where: str) -> Any:
    try:
        return json.loads(text, parse_int=_parse_int)
    except json.JSONDecodeError as exc:
        raise InvalidMapError(
            f"{where}: malformed JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}"
        ) from None
    except InvalidMapError as exc:
        raise InvalidMapError(f"{where}: {exc}") from None
    except RecursionError:
        raise InvalidMapError(f"{where}: JSON nested too deeply (a map needs 3 or 4 levels of "
                              "arrays)") from None
    except ValueError as exc:  # e.g. Python's limit on integer digits
        raise InvalidMapError(f"{where}: unreadable JSON ({' '.join(str(exc).split())})") \
            from None

# ---------------------------------------------------------------------- files
def read_polygon(path: str | Path) -> Environment:
    """Read a polygon map file: ``.wkt`` is WKT, any other suffix JSON (tether's form, or
    GeoJSON when the object has a ``type``). A map without a name is named after the file.

    Files must be text: UTF-8 (UTF-16/32 JSON is also read), at most ``MAX_MAP_BYTES`` bytes
    and ``MAX_VERTICES`` vertices (:mod:`tether.tolerances`).

    Raises
    ------
    InvalidMapError
        If the file is missing, binary, too large, malformed, of the wrong JSON types, or the
        polygon is invalid. The message names the file and, for JSON, the line and column or
        the field (``holes[0][2][1]``).
    """
    p = Path(path)
    where = str(path)
    suffix = p.suffix.lower()
    try:
        if p.is_dir():
            raise InvalidMapError(f"{where}: is a folder, not a map file")
        size = p.stat().st_size
        if size > MAX_MAP_BYTES:
            raise InvalidMapError(f"{where}: {size} bytes, larger than tether reads "
                                  f"({MAX_MAP_BYTES} bytes)")
        raw = p.read_bytes()
    except InvalidMapError:
        raise
    except ValueError as exc:  # an embedded NUL byte
        raise InvalidMapError(f"{where!r}: not a usable file name ({exc})") from None
    except OSError as exc:
        raise InvalidMapError(f"{where}: cannot read ({exc.strerror or exc})") from None
    if not raw.strip():
        raise InvalidMapError(f"{where}: the file is empty")
    text = _decode(raw, where, json_like=suffix != ".wkt")
    if suffix == ".wkt":
        return from_wkt(text, where, p.stem)
    data = _parse_json(text, where)
    if isinstance(data, dict) and "type" in data:
        return from_geojson(data, where, p.stem)
    return from_dict(data, where, p.stem)


def to_json(env: Environment) -> str:
    """The text of ``env``'s tether JSON file (:meth:`Environment.to_dict`, indented)."""
    return json.dumps(env.to_dict(), indent=1) + "\n"


def to_geojson(env: Environment) -> str:
    """The text of ``env``'s GeoJSON file: a Feature holding a Polygon (closed rings) and the
    map's name."""
    rings = [[*r.tolist(), r[0].tolist()] for r in env.rings]
    feature = {"type": "Feature", "properties": {"name": env.name},
               "geometry": {"type": "Polygon", "coordinates": rings}}
    return json.dumps(feature, indent=1) + "\n"


def to_wkt(env: Environment) -> str:
    """The text of ``env``'s WKT file: a ``POLYGON`` at full precision."""
    return shapely.to_wkt(env.polygon, rounding_precision=-1) + "\n"


_WRITERS = {".json": to_json, ".geojson": to_geojson, ".wkt": to_wkt}


def text_of(env: Environment, suffix: str) -> str:
    """The text of ``env``'s file with this suffix (``.json``, ``.geojson`` or ``.wkt``)."""
    return _WRITERS[suffix.lower()](env)


def write_polygon(env: Environment, path: str | Path) -> None:
    """Write ``env`` to ``path`` in the format of its suffix (``.json``, ``.geojson`` or
    ``.wkt``), whole or not at all (:func:`tether._util.files.atomic_output`)."""
    from tether._util.files import atomic_output

    with atomic_output(path) as tmp:
        Path(tmp).write_text(text_of(env, Path(path).suffix))
