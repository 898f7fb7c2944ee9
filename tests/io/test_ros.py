"""ROS occupancy maps: reader, pinch closing, vectorizing, rasterizing, convert round trips.

Every map is built here as a small PGM + YAML pair; the polygon is checked against the pixels
with independent computations (cell counts, obstacle components labelled by scipy, rasterizing
the polygon back at the cells' centres).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from PIL import Image
from scipy import ndimage

from tether.cli import main
from tether.environment import Environment
from tether.errors import InvalidMapError, InvalidParameterError
from tether.io import load_map
from tether.io.ros import (
    FREE,
    OCCUPIED,
    OccupancyGrid,
    close_pinches,
    free_component,
    rasterize,
    read_grid,
    read_ros_map,
    vectorize,
)

F, O, U = 254, 0, 205  # map_saver pixel values: free, occupied, unknown


def write_map(tmp_path, img, res=0.1, origin=(0.0, 0.0, 0.0), name="m", negate=0,
              mode=None, suffix=".pgm"):
    """Write ``img`` (uint8, row 0 at the top) and its YAML; return the YAML path."""
    Image.fromarray(np.asarray(img, dtype=np.uint8), mode="L").save(tmp_path / f"{name}{suffix}")
    lines = [f"image: {name}{suffix}", f"resolution: {res}",
             f"origin: [{origin[0]}, {origin[1]}, {origin[2]}]", f"negate: {negate}",
             "occupied_thresh: 0.65", "free_thresh: 0.196"]
    if mode:
        lines.append(f"mode: {mode}")
    yp = tmp_path / f"{name}.yaml"
    yp.write_text("\n".join(lines) + "\n")
    return yp


def room(h=30, w=40, wall=2):
    """A walled room: occupied border ``wall`` cells thick, free inside."""
    img = np.full((h, w), O, dtype=np.uint8)
    img[wall:-wall, wall:-wall] = F
    return img


def boundary_pixels(mask: np.ndarray) -> int:
    """Free cells with a 4-neighbour that is not free (the cells the boundary runs along)."""
    p = np.pad(mask, 1)
    inner = p[1:-1, 1:-1] & p[:-2, 1:-1] & p[2:, 1:-1] & p[1:-1, :-2] & p[1:-1, 2:]
    return int(mask.sum() - inner.sum())


def inner_obstacle_components(mask: np.ndarray) -> int:
    """Obstacle components (8-connected) that do not reach the grid's outside: the holes."""
    labels, n = ndimage.label(~np.pad(mask, 1), structure=np.ones((3, 3)))
    return n - 1 if labels[0, 0] else n


# ---------------------------------------------------------------------- basic maps
def test_room_with_pillar_origin_and_area(tmp_path):
    img = room()
    img[12:16, 18:22] = O  # a 4 x 4 pillar
    env = read_ros_map(write_map(tmp_path, img, res=0.1, origin=(1.0, 2.0, 0.0)))
    assert len(env.holes) == 1
    assert env.n == 8  # two rectangles
    free_cells = int((img == F).sum())
    assert env.area == pytest.approx(free_cells * 0.01, rel=1e-9)
    # the free box spans columns 2..37 and image rows 2..27 (map rows 2..27 from the bottom)
    assert env.bounds == pytest.approx((1.2, 2.2, 4.8, 4.8))
    pillar = env.holes[0]
    assert pillar.min(axis=0) == pytest.approx([1.0 + 1.8, 2.0 + 1.4])
    assert pillar.max(axis=0) == pytest.approx([1.0 + 2.2, 2.0 + 1.8])


def test_unknown_cells_are_obstacles(tmp_path):
    img = room()
    img[2:8, 2:10] = U  # an unscanned corner
    img[20:22, 20:22] = U  # an unscanned blob inside: a hole
    env = read_ros_map(write_map(tmp_path, img), min_hole_area=0)
    assert env.area == pytest.approx(int((img == F).sum()) * 0.01)
    assert len(env.holes) == 1
    assert not env.contains(0.25, 2.6)  # inside the corner (x col 2.5, y from bottom 26.5)


def test_door_joins_two_rooms_and_seed_selects_component(tmp_path):
    img = np.full((20, 41), O, dtype=np.uint8)
    img[2:18, 2:20] = F       # left room, 16 x 18
    img[2:18, 21:30] = F      # right room, 16 x 9
    img[12:15, 34:38] = F     # a closet of its own, 3 x 4
    img[8:11, 20] = F         # a 3-cell door between the rooms
    yp = write_map(tmp_path, img, res=0.05)
    env = read_ros_map(yp, simplify=0)
    assert env.area == pytest.approx((16 * 18 + 16 * 9 + 3) * 0.0025)
    simple = read_ros_map(yp)  # one cell: the door's jambs may be cut, within a cell per pixel
    assert abs(simple.area - env.area) <= boundary_pixels(img == F) * 0.0025
    closet = read_ros_map(yp, seed_point=(35 * 0.05 + 0.01, (20 - 13) * 0.05 + 0.01))
    assert closet.area == pytest.approx(12 * 0.0025)
    with pytest.raises(InvalidMapError, match=r"seed point \(0\.01, 0\.01\).*occupied"):
        read_ros_map(yp, seed_point=(0.01, 0.01))
    with pytest.raises(InvalidMapError, match="outside the map"):
        read_ros_map(yp, seed_point=(-5, 0))


def test_yaw_rotates_into_the_map_frame(tmp_path):
    img = room(20, 30)
    img[8:11, 12:15] = O
    plain = read_ros_map(write_map(tmp_path, img, name="a"))
    yaw = math.pi / 2
    turned = read_ros_map(write_map(tmp_path, img, origin=(2.0, -1.0, yaw), name="b"))
    assert turned.area == pytest.approx(plain.area)
    # (x, y) in the grid frame maps to (2 - y, -1 + x)
    expect = np.column_stack((2.0 - plain.boundary[:, 1], -1.0 + plain.boundary[:, 0]))
    assert np.allclose(np.sort(turned.boundary, axis=0), np.sort(expect, axis=0))
    assert len(turned.holes) == 1


def test_negate_and_raw_mode(tmp_path):
    img = room()
    img[10:14, 10:14] = O
    ref = read_ros_map(write_map(tmp_path, img, name="ref"))
    neg = read_ros_map(write_map(tmp_path, 255 - img, negate=1, name="neg"))
    assert neg.area == pytest.approx(ref.area)
    neg = read_ros_map(write_map(tmp_path, 255 - img, negate="true", name="neg2"))
    assert neg.area == pytest.approx(ref.area)
    raw = np.where(img == F, 0, np.where(img == O, 100, 255)).astype(np.uint8)
    r = read_ros_map(write_map(tmp_path, raw, mode="raw", name="raw"))
    assert r.area == pytest.approx(ref.area)


def test_png_image_and_load_map_dispatch(tmp_path):
    img = room()
    yp = write_map(tmp_path, img, suffix=".png")
    env = load_map(yp)
    assert env.name == "m" and env.area == pytest.approx(int((img == F).sum()) * 0.01)


# ---------------------------------------------------------------------- pinches
def test_close_pinches_removes_every_corner_contact():
    m = np.array([[1, 0, 1],
                  [0, 1, 0],
                  [1, 0, 1]], dtype=bool)
    out = close_pinches(m)
    p = np.pad(out, 1)
    a, b, c, d = p[:-1, :-1], p[:-1, 1:], p[1:, :-1], p[1:, 1:]
    assert not np.any((a & d & ~b & ~c) | (b & c & ~a & ~d))
    assert np.all(out <= m)  # free space only shrinks
    with pytest.raises(InvalidMapError, match="MultiPolygon"):
        vectorize(m)  # the edges do not close into rings; the union falls apart


def test_diagonal_pinches_give_a_valid_polygon(tmp_path):
    img = room(30, 30)
    img[10, 10] = O
    img[11, 11] = O            # two obstacle cells touching at a corner
    img[2, 15] = F
    img[1, 16] = F             # not reachable by an edge
    img[20, 3] = O             # an obstacle cell touching the wall at a corner ...
    img[21, 2] = F             # ... through a free cell in the wall
    img[5, 20:23] = O
    img[6, 23] = O             # a hole with a corner contact to itself? (a bent bar)
    env = read_ros_map(write_map(tmp_path, img), simplify=0, min_hole_area=0)
    assert env.polygon.is_valid
    for h in env.holes:
        assert env.polygon.exterior.distance(Environment(h).polygon) > 0


@pytest.mark.parametrize("seed", range(6))
def test_random_maps_match_their_pixels(tmp_path, seed):
    rng = np.random.default_rng(seed)
    noise = ndimage.uniform_filter(rng.random((48, 56)), 3)
    img = np.where(noise > 0.47, F, np.where(rng.random(noise.shape) < 0.3, U, O))
    img = img.astype(np.uint8)
    img[[0, -1], :] = O
    img[:, [0, -1]] = O
    yp = write_map(tmp_path, img, res=0.05, origin=(-1.0, 0.5, 0.0))
    grid = read_grid(yp)
    mask = free_component(grid)
    # exact vectorizing: the polygon holds exactly the kept cells, and every hole is found
    exact = read_ros_map(yp, simplify=0, min_hole_area=0)
    assert exact.area == pytest.approx(mask.sum() * 0.0025, rel=1e-9)
    assert len(exact.holes) == inner_obstacle_components(mask)
    assert vectorize(mask).equals(vectorize(mask, method="union"))
    back = rasterize(exact, 0.05, origin=(-1.0, 0.5))
    rows, cols = mask.shape
    assert np.array_equal(back.free[:rows, :cols], mask)
    # simplified (default one cell): within one cell per boundary pixel
    env = read_ros_map(yp)
    assert env.polygon.is_valid
    assert abs(env.area - exact.area) <= boundary_pixels(mask) * 0.0025
    # dropped holes are all small
    assert len(env.holes) <= len(exact.holes)


@settings(max_examples=40, deadline=None)
@given(arrays(bool, st.tuples(st.integers(2, 14), st.integers(2, 14))),
       st.floats(-math.pi, math.pi))
@pytest.mark.slow
def test_any_grid_gives_a_valid_map_matching_its_cells(free, yaw):
    """Property: for any grid with a free cell, the exact polygon holds exactly the kept cells,
    one hole per enclosed obstacle component, in any frame."""
    if not free.any():
        return
    grid = OccupancyGrid(np.where(free, FREE, OCCUPIED), 0.1, (0.3, -0.2, yaw))
    mask = free_component(grid)
    assert mask.sum() >= 1 and np.all(mask <= free)
    env = grid.to_environment(simplify=0, min_hole_area=0)
    assert env.area == pytest.approx(mask.sum() * 0.01, rel=1e-6)  # vertices rounded to 1e-9
    assert len(env.holes) == inner_obstacle_components(mask)
    centres = grid.to_world(np.stack(np.meshgrid(np.arange(mask.shape[1]) + 0.5,
                                                 np.arange(mask.shape[0]) + 0.5), axis=-1))
    assert np.array_equal(env.contains(centres[..., 0], centres[..., 1]), mask)
    assert grid.to_environment().polygon.is_valid
    assert vectorize(mask).equals(vectorize(mask, method="union"))  # two ways, one polygon


# ---------------------------------------------------------------------- errors
@pytest.mark.parametrize("text, match", [
    ("image: m.pgm\nresolution: 0.1\nfoo: 1\n", "unknown key"),
    ("image: m.pgm\n", "missing key 'resolution'"),
    ("image: m.pgm\nresolution: -1\n", "'resolution' must be > 0"),
    ("image: nothere.pgm\nresolution: 0.1\n", "not found"),
    ("image: m.pgm\nresolution: 0.1\nmode: fancy\n", "'mode' must be one of"),
    ("image: m.pgm\nresolution: 0.1\norigin: [1, a]\n", "'origin'"),
    ("image: [m.pgm\n", "malformed YAML"),
])
def test_yaml_errors_name_the_problem(tmp_path, text, match):
    write_map(tmp_path, room())
    (tmp_path / "m.yaml").write_text(text)
    with pytest.raises(InvalidMapError, match=match):
        read_ros_map(tmp_path / "m.yaml")


def test_no_free_cell_and_bad_options(tmp_path):
    with pytest.raises(InvalidMapError, match="no free cell"):
        read_ros_map(write_map(tmp_path, np.zeros((5, 5)), name="z"))
    yp = write_map(tmp_path, room())
    with pytest.raises(InvalidParameterError):
        read_ros_map(yp, simplify=-1)


def test_hole_messages_give_locations():
    with pytest.raises(InvalidMapError, match=r"vertex V4 \(0, 1\) of hole 0 lies on edge E3"):
        Environment([[0, 0], [4, 0], [4, 4], [0, 4]], ([[0, 1], [1, 1], [1, 2]],))
    with pytest.raises(InvalidMapError, match=r"holes 0 and 1 overlap near \(1.75, 1.75\)"):
        Environment([[0, 0], [4, 0], [4, 4], [0, 4]],
                    ([[1, 1], [2, 1], [2, 2], [1, 2]], [[1.5, 1.5], [3, 1.5], [3, 3], [1.5, 3]]))
    # diagonal obstacle cells touching at a corner (a vertex of both): a valid map
    Environment([[0, 0], [4, 0], [4, 4], [0, 4]],
                ([[1, 1], [2, 1], [2, 2], [1, 2]], [[2, 2], [3, 2], [3, 3], [2, 3]]))


# ---------------------------------------------------------------------- round trips
def test_rasterize_save_read_round_trip(tmp_path):
    env = Environment([[0, 0], [3, 0], [3, 2], [0, 2]], ([[1.2, 0.8], [1.6, 0.8], [1.6, 1.2],
                                                           [1.2, 1.2]],), "box")
    grid = rasterize(env, 0.05, origin=(-0.1, -0.1))
    assert set(np.unique(grid.cells)) == {FREE, OCCUPIED}
    grid.save(tmp_path / "box.yaml")
    back = read_ros_map(tmp_path / "box.yaml")
    assert back.area == pytest.approx(env.area)
    assert back.bounds == pytest.approx(env.bounds)
    assert np.allclose(np.sort(back.holes[0], axis=0), np.sort(env.holes[0], axis=0))


def test_convert_cli_round_trip(tmp_path, capsys):
    img = room()
    img[12:16, 18:22] = O
    yp = write_map(tmp_path, img, origin=(0.5, 0.5, 0.0))
    ref = read_ros_map(yp)
    for ext in (".json", ".geojson", ".wkt"):
        out = tmp_path / f"out{ext}"
        assert main(["convert", str(yp), str(out)]) == 0
        assert "kept 920 of 920 free cells" in capsys.readouterr().out
        env = load_map(out)
        assert env.area == pytest.approx(ref.area)
        assert np.allclose(env.vertices, ref.vertices)
    assert json.loads((tmp_path / "out.geojson").read_text())["type"] == "Feature"
    out = tmp_path / "again.yaml"
    assert main(["convert", str(tmp_path / "out.json"), str(out), "--resolution", "0.1"]) == 0
    assert load_map(out).area == pytest.approx(ref.area)
    capsys.readouterr()
    assert main(["convert", str(tmp_path / "out.json"), str(tmp_path / "x.json"),
                 "--seed", "1", "1"]) == 2
    assert main(["convert", str(yp), str(tmp_path / "x.txt")]) == 2
    assert main(["convert", str(yp), str(tmp_path / "x.yaml")]) == 2  # needs --resolution
    err = capsys.readouterr().err
    assert err.count("tether: error:") == 3


def test_office_example(capsys):
    from tether.examples import path as example_path

    yp = example_path("office").with_suffix(".yaml")
    env = read_ros_map(yp)
    assert env.polygon.is_valid and len(env.holes) == 2  # pillar and table; speckles dropped
    assert main(["info", str(yp)]) == 0
    assert "2 holes" in capsys.readouterr().out
    conv = read_grid(yp).convert()
    assert conv.dropped_holes == 3  # the three one-cell speckles
    assert conv.kept_cells == read_grid(yp).convert(min_hole_area=0).kept_cells
    assert conv.free_cells - conv.kept_cells == 23 * 23  # the closed closet
    assert conv.exact_vertices == 40 + 3 * 4 and conv.env.n == 40
    assert json.loads(json.dumps(conv.to_dict()))["holes"] == 2


def test_rgb_png_and_free_cells_on_the_image_border(tmp_path):
    img = np.full((12, 16), F, dtype=np.uint8)  # free up to the image's edge
    img[5:7, 6:9] = O
    rgb = np.repeat(img[..., None], 3, axis=2)
    Image.fromarray(rgb, mode="RGB").save(tmp_path / "c.png")
    (tmp_path / "c.yaml").write_text("image: c.png\nresolution: 0.5\norigin: [0, 0, 0]\n")
    env = read_ros_map(tmp_path / "c.yaml")
    assert env.bounds == pytest.approx((0, 0, 8, 6))
    assert env.area == pytest.approx((12 * 16 - 6) * 0.25) and len(env.holes) == 1


def test_occupancy_is_a_deprecated_alias_of_io_ros():
    import importlib
    import sys

    import tether.io.ros as ros

    sys.modules.pop("tether.occupancy", None)
    with pytest.warns(DeprecationWarning, match="tether.io.ros"):
        old = importlib.import_module("tether.occupancy")
    assert old.read_ros_map is ros.read_ros_map and old.OccupancyGrid is ros.OccupancyGrid
    assert set(ros.__all__) <= set(old.__all__)
