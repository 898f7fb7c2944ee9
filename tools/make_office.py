"""Generate ``office.yaml`` + ``office.pgm``: a small ROS ``map_server`` map of an office.

A 13 m x 8 m floor at 5 cm per cell, as ``map_saver`` writes it (254 free, 0 occupied,
205 unknown): a corridor along the bottom, three rooms above it, each with a 0.9 m door, a pillar
in the corridor, a table in the middle room, a cupboard corner nobody scanned (unknown), a closed
closet (a free component of its own), sensor speckles (single occupied cells) and unknown space
outside the walls. The map frame's origin is offset, as in a real SLAM map.

Run ``python tools/make_office.py [OUT_DIR]`` (default: the packaged ``src/tether/examples``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

RES = 0.05  # metres per cell
ORIGIN = (-2.0, -1.5, 0.0)  # pose of the lower-left cell corner in the map frame
W, H = 300, 200  # cells (15 m x 10 m image)
FREE, OCC, UNK = 254, 0, 205


def _cells(x: float) -> int:
    return int(round(x / RES))


def _fill(img: np.ndarray, x0: float, y0: float, x1: float, y1: float, value: int) -> None:
    """Fill the rectangle [x0, x1] x [y0, y1] (metres from the image's lower-left corner)."""
    r0, r1 = H - _cells(y1), H - _cells(y0)  # image rows run top-down
    img[r0:r1, _cells(x0):_cells(x1)] = value


def office() -> np.ndarray:
    """The office image, uint8, row 0 at the top."""
    img = np.full((H, W), UNK, dtype=np.uint8)
    x0, y0, x1, y1 = 1.0, 1.0, 14.0, 9.0  # outer face of the building walls
    t = 0.15  # wall thickness
    _fill(img, x0, y0, x1, y1, OCC)
    _fill(img, x0 + t, y0 + t, x1 - t, y1 - t, FREE)
    # corridor 2.2 m high along the bottom; wall above it with three doors
    yc = y0 + t + 2.2
    _fill(img, x0, yc, x1, yc + t, OCC)
    for door_x in (3.0, 7.4, 11.6):
        _fill(img, door_x, yc, door_x + 0.9, yc + t, FREE)
    # walls between the rooms
    for wx in (5.5, 9.8):
        _fill(img, wx, yc, wx + t, y1, OCC)
    # pillar in the corridor, table in the middle room
    _fill(img, 8.2, 2.0, 8.6, 2.4, OCC)
    _fill(img, 6.6, 5.6, 8.4, 6.6, OCC)
    # a cupboard corner of the right room that the robot never saw
    _fill(img, 12.6, 7.6, 13.85, 8.85, UNK)
    # a closed closet in the left room's corner (free, but not reachable)
    _fill(img, 1.15, 7.4, 2.6, 8.85, OCC)
    _fill(img, 1.3, 7.55, 2.45, 8.7, FREE)
    # sensor speckles: single occupied cells in the free space
    for sx, sy in ((4.0, 5.0), (12.0, 4.5), (6.0, 2.0)):
        _fill(img, sx, sy, sx + RES, sy + RES, OCC)
    return img


def write(out_dir: Path) -> Path:
    """Write ``office.pgm`` and ``office.yaml`` into ``out_dir``; return the YAML path."""
    from PIL import Image

    out_dir.mkdir(parents=True, exist_ok=True)
    Image.fromarray(office(), mode="L").save(out_dir / "office.pgm")
    yaml_path = out_dir / "office.yaml"
    yaml_path.write_text(
        "image: office.pgm\n"
        "mode: trinary\n"
        f"resolution: {RES}\n"
        f"origin: [{ORIGIN[0]}, {ORIGIN[1]}, {ORIGIN[2]}]\n"
        "negate: 0\n"
        "occupied_thresh: 0.65\n"
        "free_thresh: 0.196\n"
    )
    return yaml_path


if __name__ == "__main__":
    outs = ([Path(a) for a in sys.argv[1:]]
            or [Path(__file__).resolve().parents[1] / "src" / "tether" / "examples"])
    for d in outs:
        print(write(d))
