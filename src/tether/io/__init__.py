"""Map files, read and written: polygon maps (tether's JSON form, GeoJSON, WKT;
:mod:`tether.io.polygon`) and ROS occupancy maps (``map_server`` YAML + image;
:mod:`tether.io.ros`). :func:`load_map` and :func:`save_map` pick the format by the file's
suffix."""

from __future__ import annotations

from pathlib import Path

from tether.environment import Environment
from tether.errors import InvalidMapError, InvalidParameterError
from tether.io.polygon import SUFFIXES as POLYGON_SUFFIXES
from tether.io.polygon import (
    from_dict,
    from_geojson,
    from_wkt,
    read_polygon,
    to_geojson,
    to_json,
    to_wkt,
    write_polygon,
)
from tether.io.ros import OccupancyGrid, rasterize, read_grid, read_ros_map

__all__ = [
    "OccupancyGrid",
    "from_dict",
    "from_geojson",
    "from_wkt",
    "load_map",
    "rasterize",
    "read_grid",
    "read_polygon",
    "read_ros_map",
    "save_map",
    "to_geojson",
    "to_json",
    "to_wkt",
]

#: The file suffixes of ROS ``map_server`` maps.
ROS_SUFFIXES = (".yaml", ".yml")


def load_map(path: str | Path) -> Environment:
    """Read a map file: ``.json`` (tether's form or GeoJSON), ``.geojson``, ``.wkt``, or a ROS
    ``map_server`` map ``.yaml`` (see :func:`tether.io.ros.read_ros_map`, default options).

    Files must be text: UTF-8 (UTF-16/32 JSON is also read), at most ``MAX_MAP_BYTES`` bytes
    and ``MAX_VERTICES`` vertices (:mod:`tether.tolerances`). A map without a name is named after
    the file.

    Raises
    ------
    InvalidMapError
        If the file is missing, of an unknown format, binary, too large, malformed, of the wrong
        JSON types, or the polygon is invalid. The message names the file and, for JSON, the
        line and column or the field (``holes[0][2][1]``).
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix in ROS_SUFFIXES:
        return read_ros_map(p)
    if suffix not in POLYGON_SUFFIXES:
        raise InvalidMapError(f"{path}: unknown map format {suffix or '(none)'!r}; "
                              "use .json, .geojson, .wkt or a ROS map .yaml")
    return read_polygon(path)


def save_map(env: Environment, path: str | Path, *, resolution: float | None = None) -> None:
    """Write ``env`` to ``path`` in the format of its suffix, whole or not at all: ``.json``
    (tether's form), ``.geojson``, ``.wkt``, or a ROS ``map_server`` map ``.yaml`` (with its
    ``.pgm`` image beside it; rasterized at ``resolution`` map units per cell, see
    :func:`tether.io.ros.rasterize`).

    Raises
    ------
    OutputPathError
        If the suffix is none of these, or the path cannot be written
        (:func:`tether._util.files.check_output_path`).
    InvalidParameterError
        If a ROS map is asked for without ``resolution``, or a polygon map with one.
    """
    from tether._util.files import check_output_path

    p = check_output_path(path, (*POLYGON_SUFFIXES, *ROS_SUFFIXES))
    ros = p.suffix.lower() in ROS_SUFFIXES
    if ros and resolution is None:
        raise InvalidParameterError("writing a ROS map (.yaml) needs a resolution (map units "
                                    "per cell)")
    if not ros and resolution is not None:
        raise InvalidParameterError("resolution applies to a ROS map (.yaml) only")
    if ros:
        rasterize(env, resolution).save(p)
    else:
        write_polygon(env, p)
