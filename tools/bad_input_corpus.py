"""A corpus of bad and degenerate inputs for the ``tether`` command, run in-process.

Each case writes its input files into a fresh temporary folder, runs ``tether.cli.main(argv)``
there with stdout/stderr captured, and is classified as

* ``ok``            exit 0 (or 1 for ``check``) and the case allows success;
* ``clean error``   exit 2 with exactly one line on stderr (``...: error: ...``);
* ``multi-line``    exit 2 but more than one line on stderr (usage text, warnings...);
* ``internal``      exit 3 (``tether: internal error``): a bug, reported on one line;
* ``traceback``     an exception escaped ``main`` or stderr holds a traceback;
* ``wrong exit``    an exit status the case does not allow (``--samples 0`` exiting 0...);
* ``file left``     a file other than the expected output appeared (or any file on error);
* ``timeout``       the case ran longer than its limit.

Usage::

    python tools/bad_input_corpus.py            # this checkout
    python tools/bad_input_corpus.py -v         # one row per case
    PYTHONPATH=/path/to/other/src python tools/bad_input_corpus.py   # another version

The table counts outcomes per input class; the exit status is the number of cases that are
neither ``ok`` nor ``clean error``.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import random
import signal
import sys
import tempfile
import time
from collections import Counter, defaultdict
from dataclasses import dataclass, field
from pathlib import Path

OK, CLEAN, MULTI, INTERNAL, TRACE, WRONG, LEFT, TIMEOUT = (
    "ok", "clean error", "multi-line", "internal", "traceback", "wrong exit", "file left",
    "timeout")
OUTCOMES = [OK, CLEAN, MULTI, INTERNAL, TRACE, WRONG, LEFT, TIMEOUT]

SQUARE = {"boundary": [[0, 0], [4, 0], [4, 3], [0, 3]], "holes": [], "name": "square"}
HOLED = {"boundary": [[0, 0], [8, 0], [8, 6], [0, 6]],
         "holes": [[[3, 2], [5, 2], [5, 4], [3, 4]]], "name": "holed"}


@dataclass
class Case:
    """One run: ``files`` written first (name -> bytes), then ``tether *argv``."""

    klass: str
    name: str
    argv: list[str]
    files: dict[str, bytes] = field(default_factory=dict)
    allow: tuple[int, ...] = (2,)          # exit statuses that are right
    outputs: tuple[str, ...] = ()          # files expected on success
    setup: object = None                   # callable(folder) run before the case
    limit: int = 60                        # seconds


def js(obj: object) -> bytes:
    return json.dumps(obj).encode()


def map_case(klass: str, name: str, filename: str, content: bytes,
             allow: tuple[int, ...] = (2,), cmd: str = "info") -> Case:
    argv = {"info": ["info", filename],
            "arcs": ["arcs", filename, "--lss", "1", "--at", "1", "1"],
            "decompose": ["decompose", filename, "--lss", "1"]}[cmd]
    return Case(klass, name, argv, {filename: content}, allow)


# ---------------------------------------------------------------------- map files
def encoding_cases() -> list[Case]:
    text = json.dumps(SQUARE)
    wkt = "POLYGON ((0 0, 4 0, 4 3, 0 3, 0 0))"
    rnd = random.Random(1)
    cases = [
        map_case("encoding", "utf-16 with BOM", "m.json", text.encode("utf-16"), (0, 2)),
        map_case("encoding", "utf-16-le no BOM", "m.json", text.encode("utf-16-le"), (0, 2)),
        map_case("encoding", "utf-16-be no BOM", "m.json", text.encode("utf-16-be"), (0, 2)),
        map_case("encoding", "utf-32 with BOM", "m.json", text.encode("utf-32"), (0, 2)),
        map_case("encoding", "utf-32-le no BOM", "m.json", text.encode("utf-32-le"), (0, 2)),
        map_case("encoding", "utf-8 with BOM", "m.json", text.encode("utf-8-sig"), (0, 2)),
        map_case("encoding", "utf-16 geojson", "m.geojson", json.dumps(
            {"type": "Polygon", "coordinates": [SQUARE["boundary"]]}).encode("utf-16"), (0, 2)),
        map_case("encoding", "latin-1 name in json", "m.json",
                 json.dumps({**SQUARE, "name": "café"}, ensure_ascii=False).encode("latin-1")),
        map_case("encoding", "latin-1 wkt", "m.wkt", (wkt + " -- caf\xe9").encode("latin-1")),
        map_case("encoding", "utf-16 wkt", "m.wkt", wkt.encode("utf-16"), (0, 2)),
        map_case("encoding", "utf-16-le wkt no BOM", "m.wkt", wkt.encode("utf-16-le")),
        map_case("encoding", "empty file", "m.json", b""),
        map_case("encoding", "whitespace only", "m.json", b" \n\t\n"),
        map_case("encoding", "empty wkt", "m.wkt", b""),
        map_case("encoding", "png header", "m.json", b"\x89PNG\r\n\x1a\n" + bytes(200)),
        map_case("encoding", "gzip data", "m.json", b"\x1f\x8b\x08\x00" + bytes(range(256))),
        map_case("encoding", "NUL inside json", "m.json", text.encode()[:20] + b"\x00"
                 + text.encode()[20:]),
        map_case("encoding", "surrogate escape", "m.json",
                 json.dumps({**SQUARE, "name": "\ud800"}).encode()),
    ]
    for seed in range(6):
        blob = bytes(rnd.randrange(256) for _ in range(rnd.randrange(1, 2000)))
        ext = ["m.json", "m.wkt", "m.geojson"][seed % 3]
        cases.append(map_case("encoding", f"random bytes #{seed}", ext, blob))
    return cases


def json_syntax_cases() -> list[Case]:
    t = json.dumps(SQUARE)
    cases = [
        ("truncated", t[: len(t) // 2]),
        ("trailing comma", t[:-1] + ",}"),
        ("NaN literal", t.replace("[4, 3]", "[NaN, 3]")),
        ("Infinity literal", t.replace("[4, 3]", "[Infinity, 3]")),
        ("-Infinity literal", t.replace("[4, 3]", "[-Infinity, 3]")),
        ("1e400", t.replace("[4, 3]", "[1e400, 3]")),
        ("-1e400", t.replace("[4, 3]", "[-1e400, 3]")),
        ("5000-digit int", t.replace("[4, 3]", "[" + "9" * 5000 + ", 3]")),
        ("400-digit int", t.replace("[4, 3]", "[" + "9" * 399 + ", 3]")),
        ("310-digit int", t.replace("[4, 3]", "[1" + "0" * 310 + ", 3]")),
        ("deep arrays 100k", "[" * 100_000 + "]" * 100_000),
        ("deep arrays 5k", "[" * 5000 + "]" * 5000),
        ("deep objects", '{"a":' * 50_000 + "1" + "}" * 50_000),
        ("deep boundary", t.replace("[[0, 0]", "[" * 3000 + "0" + "]" * 3000 + ", [[0, 0]")),
        ("top-level array", "[[0, 0], [1, 0], [0, 1]]"),
        ("top-level string", '"boundary"'),
        ("top-level number", "42"),
        ("top-level null", "null"),
        ("top-level true", "true"),
        ("duplicate keys", t[:-1] + ', "boundary": [[0, 0], [1, 0]]}'),
        ("comment", "// map\n" + t),
        ("single quotes", t.replace('"', "'")),
        ("bare words", "boundary: [[0,0],[1,0],[0,1]]"),
    ]
    return [map_case("json syntax", n, "m.json", c.encode()) for n, c in cases] + [
        map_case("json syntax", "huge string name", "m.json",
                 js({**SQUARE, "name": "x" * 2_000_000}), (0, 2))]


def json_type_cases() -> list[Case]:
    b = SQUARE["boundary"]
    cases = [
        ("boundary string", {"boundary": "0 0 4 0 4 3"}),
        ("boundary object", {"boundary": {"x": [0, 4, 4], "y": [0, 0, 3]}}),
        ("boundary null", {"boundary": None}),
        ("boundary number", {"boundary": 3}),
        ("coordinate string", {"boundary": [[0, 0], [4, "0"], [4, 3]]}),
        ("coordinate bool", {"boundary": [[0, 0], [True, 0], [4, 3]]}),
        ("coordinate null", {"boundary": [[0, 0], [4, None], [4, 3]]}),
        ("coordinate list", {"boundary": [[0, 0], [4, [0]], [4, 3]]}),
        ("coordinate object", {"boundary": [[0, 0], [4, {"v": 0}], [4, 3]]}),
        ("point of 1", {"boundary": [[0, 0], [4], [4, 3]]}),
        ("point of 3", {"boundary": [[0, 0, 0], [4, 0, 0], [4, 3, 0]]}),
        ("point is number", {"boundary": [0, 0, 4, 0, 4, 3]}),
        ("point is object", {"boundary": [{"x": 0, "y": 0}, {"x": 4, "y": 0}, {"x": 4, "y": 3}]}),
        ("holes object", {"boundary": b, "holes": {"0": []}}),
        ("holes string", {"boundary": b, "holes": "none"}),
        ("hole is ring not list", {"boundary": b, "holes": [[1, 1], [2, 1], [1, 2]]}),
        ("hole coord string", {"boundary": b, "holes": [[[1, 1], [2, 1], [1, "2"]]]}),
        ("hole coord bool", {"boundary": b, "holes": [[[1, 1], [2, 1], [1, False]]]}),
        ("name number", {"boundary": b, "name": 7}),
        ("name list", {"boundary": b, "name": ["a"]}),
        ("unknown key", {"boundary": b, "colour": "red"}),
        ("missing boundary", {"holes": []}),
        ("empty object", {}),
        ("empty boundary", {"boundary": []}),
        ("nested feature in tether form", {"boundary": {"type": "Feature"}}),
    ]
    return [map_case("json types", n, "m.json", js(d)) for n, d in cases]


def geometry_cases() -> list[Case]:
    sq = [[0, 0], [4, 0], [4, 4], [0, 4]]
    bad = [
        ("two vertices", {"boundary": [[0, 0], [1, 0]]}),
        ("repeated vertex", {"boundary": [[0, 0], [1, 0], [1, 0], [0, 1]]}),
        ("nearly repeated vertex", {"boundary": [[0, 0], [1, 0], [1, 1e-13], [0, 1]]}),
        ("bowtie", {"boundary": [[0, 0], [2, 2], [2, 0], [0, 2]]}),
        ("collinear ring", {"boundary": [[0, 0], [1, 0], [2, 0]]}),
        ("hole outside", {"boundary": sq, "holes": [[[5, 5], [6, 5], [6, 6]]]}),
        ("hole touching boundary", {"boundary": sq, "holes": [[[0, 1], [1, 1], [1, 2]]]}),
        ("hole crossing boundary", {"boundary": sq, "holes": [[[3, 1], [5, 1], [5, 2]]]}),
        ("holes overlapping", {"boundary": [[0, 0], [9, 0], [9, 9], [0, 9]],
                               "holes": [[[1, 1], [3, 1], [3, 3]], [[2, 1.5], [4, 1.5], [4, 4]]]}),
        ("holes touching", {"boundary": [[0, 0], [9, 0], [9, 9], [0, 9]],
                            "holes": [[[1, 1], [3, 1], [3, 3]], [[3, 1], [5, 1], [5, 3]]]}),
        ("hole in hole", {"boundary": [[0, 0], [9, 0], [9, 9], [0, 9]],
                          "holes": [[[1, 1], [8, 1], [8, 8], [1, 8]], [[2, 2], [3, 2], [3, 3]]]}),
        ("self-touching hole", {"boundary": [[0, 0], [9, 0], [9, 9], [0, 9]],
                                "holes": [[[1, 1], [3, 1], [2, 2], [3, 3], [1, 3], [2, 2]]]}),
        ("spike", {"boundary": [[0, 0], [4, 0], [4, 4], [2, 4], [2, 8], [2, 4], [0, 4]]}),
        ("huge coordinates 1e300", {"boundary": [[0, 0], [1e300, 0], [1e300, 1e300]]}),
        ("huge coordinates 1e308", {"boundary": [[-1e308, -1e308], [1e308, -1e308],
                                                 [1e308, 1e308]]}),
    ]
    cases = [map_case("geometry", n, "m.json", js(d)) for n, d in bad]
    fine = [
        ("offset 1e9 square", {"boundary": [[1e9, 1e9], [1e9 + 4, 1e9], [1e9 + 4, 1e9 + 4],
                                            [1e9, 1e9 + 4]]}),
        ("tiny square 1e-300", {"boundary": [[0, 0], [4e-300, 0], [4e-300, 4e-300],
                                             [0, 4e-300]]}),
        ("clockwise ring", {"boundary": sq[::-1]}),
        ("closing vertex repeated", {"boundary": [*sq, sq[0]]}),
        ("collinear vertex", {"boundary": [[0, 0], [2, 0], [4, 0], [4, 4], [0, 4]]}),
        ("10k vertices circle", {"boundary": _circle(10_000)}),
    ]
    cases += [map_case("geometry", n, "m.json", js(d), (0, 2)) for n, d in fine]
    cases.append(map_case("geometry", "200k vertices", "m.json",
                          js({"boundary": _circle(200_000)})))
    return cases


def _circle(n: int) -> list[list[float]]:
    import math

    return [[round(math.cos(2 * math.pi * k / n), 12), round(math.sin(2 * math.pi * k / n), 12)]
            for k in range(n)]


def geojson_cases() -> list[Case]:
    ring = [[0, 0], [4, 0], [4, 3], [0, 3], [0, 0]]
    poly = {"type": "Polygon", "coordinates": [ring]}
    bad = [
        ("Point", {"type": "Point", "coordinates": [0, 0]}),
        ("LineString", {"type": "LineString", "coordinates": ring}),
        ("MultiPolygon", {"type": "MultiPolygon", "coordinates": [[ring]]}),
        ("GeometryCollection", {"type": "GeometryCollection", "geometries": [poly]}),
        ("Feature in Feature", {"type": "Feature", "geometry": {"type": "Feature",
                                                               "geometry": poly}}),
        ("collection of 0", {"type": "FeatureCollection", "features": []}),
        ("collection of 2", {"type": "FeatureCollection", "features": [
            {"type": "Feature", "geometry": poly}] * 2}),
        ("collection in collection", {"type": "FeatureCollection", "features": [
            {"type": "FeatureCollection", "features": [{"type": "Feature", "geometry": poly}]}]}),
        ("features not list", {"type": "FeatureCollection", "features": {"a": 1}}),
        ("feature null geometry", {"type": "Feature", "geometry": None}),
        ("feature no geometry", {"type": "Feature", "properties": {}}),
        ("properties list", {"type": "Feature", "properties": [1], "geometry": poly}),
        ("name number", {"type": "Feature", "properties": {"name": 3}, "geometry": poly}),
        ("type number", {"type": 3, "coordinates": [ring]}),
        ("type null", {"type": None, "coordinates": [ring]}),
        ("unknown type", {"type": "Polygonn", "coordinates": [ring]}),
        ("coordinates string", {"type": "Polygon", "coordinates": "0 0 1 1"}),
        ("coordinates null", {"type": "Polygon", "coordinates": None}),
        ("no rings", {"type": "Polygon", "coordinates": []}),
        ("ring of numbers", {"type": "Polygon", "coordinates": [[0, 0, 4, 0, 4, 3]]}),
        ("string coordinate", {"type": "Polygon", "coordinates": [[[0, 0], [4, "0"], [4, 3]]]}),
        ("bool coordinate", {"type": "Polygon", "coordinates": [[[0, 0], [4, True], [4, 3]]]}),
        ("5-d positions", {"type": "Polygon", "coordinates": [[p + [0, 0, 0] for p in ring]]}),
        ("geometry is list", {"type": "Feature", "geometry": [poly]}),
    ]
    cases = [map_case("geojson", n, "m.geojson", js(d)) for n, d in bad]
    fine = [
        ("3-d positions", {"type": "Polygon", "coordinates": [[p + [7] for p in ring]]}),
        ("feature", {"type": "Feature", "properties": {"name": "f"}, "geometry": poly}),
        ("feature null properties", {"type": "Feature", "properties": None, "geometry": poly}),
    ]
    cases += [map_case("geojson", n, "m.geojson", js(d), (0,)) for n, d in fine]
    return cases


def wkt_cases() -> list[Case]:
    bad = [
        ("CIRCULARSTRING", "CIRCULARSTRING (0 0, 1 1, 2 0)"),
        ("CURVEPOLYGON", "CURVEPOLYGON (CIRCULARSTRING (0 0, 4 0, 4 4, 0 4, 0 0))"),
        ("MULTIPOLYGON", "MULTIPOLYGON (((0 0, 4 0, 4 3, 0 0)))"),
        ("POINT", "POINT (1 2)"),
        ("LINESTRING", "LINESTRING (0 0, 1 0)"),
        ("GEOMETRYCOLLECTION", "GEOMETRYCOLLECTION (POLYGON ((0 0, 4 0, 4 3, 0 0)))"),
        ("TRIANGLE", "TRIANGLE ((0 0, 4 0, 4 3, 0 0))"),
        ("POLYGON EMPTY", "POLYGON EMPTY"),
        ("truncated", "POLYGON ((0 0, 4 0"),
        ("garbage", "hello world"),
        ("numbers only", "0 0, 4 0, 4 3"),
        ("deep parens", "POLYGON " + "(" * 10_000 + "0 0" + ")" * 10_000),
        ("nan coordinate", "POLYGON ((0 0, nan 0, 4 3, 0 0))"),
        ("1e400 coordinate", "POLYGON ((0 0, 1e400 0, 4 3, 0 0))"),
        ("bowtie", "POLYGON ((0 0, 2 2, 2 0, 0 2, 0 0))"),
        ("unclosed ring", "POLYGON ((0 0, 4 0, 4 3))"),
        ("JSON in .wkt", json.dumps(SQUARE)),
        ("two polygons", "POLYGON ((0 0, 4 0, 4 3, 0 0)) POLYGON ((0 0, 4 0, 4 3, 0 0))"),
    ]
    cases = [map_case("wkt", n, "m.wkt", t.encode()) for n, t in bad]
    fine = [
        ("POLYGON Z", "POLYGON Z ((0 0 1, 4 0 1, 4 3 1, 0 3 1, 0 0 1))"),
        ("lower case", "polygon ((0 0, 4 0, 4 3, 0 3, 0 0))"),
        ("SRID prefix", "SRID=4326;POLYGON ((0 0, 4 0, 4 3, 0 3, 0 0))"),
    ]
    cases += [map_case("wkt", n, "m.wkt", t.encode(), (0, 2)) for n, t in fine]
    return cases


def file_cases() -> list[Case]:
    good = js(SQUARE)

    def mkdir_map(d: Path) -> None:
        (d / "dir.json").mkdir()

    return [
        Case("files", "missing file", ["info", "nope.json"]),
        Case("files", "folder as map", ["info", "dir.json"], setup=mkdir_map),
        Case("files", "unknown extension", ["info", "m.txt"], {"m.txt": good}),
        Case("files", "no extension", ["info", "m"], {"m": good}),
        Case("files", "map under a file", ["info", "m.json/x.json"], {"m.json": good}),
        Case("files", "empty path", ["info", ""]),
        Case("files", "NUL in path", ["info", "m\x00.json"]),
        Case("files", "very long name", ["info", "x" * 5000 + ".json"]),
    ]


# ---------------------------------------------------------------------- parameters
def param_cases() -> list[Case]:
    sq = {"m.json": js(SQUARE)}
    ho = {"m.json": js(HOLED)}
    cases: list[Case] = []

    def add(name, argv, files=sq, allow=(2,)):
        cases.append(Case("parameters", name, argv, files, allow))

    for v in ["0", "-1", "nan", "inf", "-inf", "1e-12", "1e308", "1e-300", "abc", "", "1e400",
              "0x10"]:
        add(f"arcs --lss {v!r}", ["arcs", "m.json", "--lss", v, "--at", "1", "1"])
        add(f"decompose --lss {v!r}", ["decompose", "m.json", "--lss", v])
    add("decompose --lss 1e-3 x diameter", ["decompose", "m.json", "--lss", "0.005"],
        allow=(0, 2))
    add("decompose --lss 1000 x diameter", ["decompose", "m.json", "--lss", "5000"], allow=(0,))
    for at in [("nan", "1"), ("inf", "1"), ("1e308", "1"), ("9", "9"), ("0", "1"),
               ("4", "3"), ("4", "4")]:
        add(f"arcs --at {' '.join(at)}", ["arcs", "m.json", "--lss", "1", "--at", *at], ho)
    for s in ["0", "-1", "1e9", "x", "10" * 20, "1.5", "1000000"]:
        add(f"check --samples {s}", ["check", "m.json", "--lss", "1", "--samples", s])
    add("check --samples 1", ["check", "m.json", "--lss", "1", "--samples", "1"],
        allow=(0, 1))
    for s in ["-1", str(2**40), "1.5", "x"]:
        add(f"check --seed {s}", ["check", "m.json", "--lss", "1", "--seed", s])
    b = ["bound", "--from", "0", "--to", "1"]
    for name, vs in [("vt 0", ("0", "2", "1")), ("vt -1", ("-1", "2", "1")),
                     ("vo = vt", ("1", "1", "1")), ("vo < vt", ("2", "1", "1")),
                     ("vo 1e308", ("1", "1e308", "1")), ("vt 1e-320", ("1e-320", "2", "1")),
                     ("lss 1e308", ("1", "2", "1e308")), ("lss 1e-320", ("1", "2", "1e-320")),
                     ("vo nan", ("1", "nan", "1")), ("vt inf", ("inf", "2", "1")),
                     ("vo - vt 1e-16", ("1", "1.0000000000000002", "1")),
                     ("all 1e300", ("1e300", "2e300", "1e300")),
                     ("all 1e-300", ("1e-300", "2e-300", "1e-300"))]:
        allow = (0,) if name == "vt 0" else (2,)
        add(f"bound {name}", [*b, "--vt", vs[0], "--vo", vs[1], "--lss", vs[2]], allow=allow)
        add(f"bound --json {name}", [*b, "--json", "--vt", vs[0], "--vo", vs[1], "--lss", vs[2]],
            allow=allow)
    for th in ["nan", "inf", "1e300", "-1e300", "1e5"]:
        add(f"bound --to {th}", ["bound", "--vt", "1", "--vo", "2", "--lss", "1",
                                 "--from", "0", "--to", th])
    for kind in ["tractrix", "rotation", "wall", "vertex"]:
        cases.append(Case("parameters", f"plot-motion {kind} --vt 0",
                          ["plot-motion", kind, "--vt", "0", "--out", "f.png"]))
        cases.append(Case("parameters", f"plot-motion {kind} vo 1e12",
                          ["plot-motion", kind, "--vo", "1e12", "--out", "f.png"],
                          allow=(0, 2), outputs=("f.png",)))
        cases.append(Case("parameters", f"plot-motion {kind} lss 1e-300",
                          ["plot-motion", kind, "--lss", "1e-300", "--out", "f.png"]))
    cases.append(Case("parameters", "plot-motion rotation --to 1e6",
                      ["plot-motion", "rotation", "--to", "1e6", "--out", "f.png"]))
    return cases


# ---------------------------------------------------------------------- output paths
def output_cases() -> list[Case]:
    sq = {"m.json": js(SQUARE), "afile": b"x"}
    cmds = {
        "decompose --plot": ["decompose", "m.json", "--lss", "1", "--plot"],
        "analyze --plot": ["analyze", "m.json", "--lss", "1", "--plot"],
        "bound --plot": ["bound", "--vt", "1", "--vo", "2", "--lss", "1", "--from", "0", "--to",
                         "1", "--plot"],
        "plot-motion --out": ["plot-motion", "wall", "--out"],
    }
    paths = {"missing folder": "nope/f.png", "under a file": "afile/f.png",
             "existing folder": ".", "folder with slash": "sub/", "no extension": "f",
             "unknown extension": "f.txt", "empty": "", "NUL": "f\x00.png"}
    cases = []

    def mksub(d: Path) -> None:
        (d / "sub").mkdir()

    for cname, argv in cmds.items():
        for pname, path in paths.items():
            cases.append(Case("output paths", f"{cname} {pname}", [*argv, path], sq,
                              setup=mksub))
        cases.append(Case("output paths", f"{cname} good .svg", [*argv, "f.svg"], sq,
                          allow=(0,), outputs=("f.svg",)))
    cases += [
        Case("output paths", "demo --out a file", ["demo", "--out", "afile"], sq),
        Case("output paths", "demo --out under a file", ["demo", "--out", "afile/d"], sq),
        Case("output paths", "demo --out empty", ["demo", "--out", ""], sq),
    ]
    return cases


def ros_cases() -> list[Case]:
    """The ``convert`` and ``sweep`` commands (ROS maps), when this version has them."""
    sq = {"m.json": js(SQUARE), "afile": b"x"}
    yaml_bad = {"r.yaml": b"image: r.pgm\nresolution: -1\norigin: [0, 0, 0]\n",
                "r.pgm": b"P5\n2 2\n255\n\x00\x00\x00\x00"}
    return [
        Case("ros", "convert to missing folder", ["convert", "m.json", "nope/m.wkt"], sq),
        Case("ros", "convert to unknown extension", ["convert", "m.json", "m.txt"], sq),
        Case("ros", "convert to a folder", ["convert", "m.json", "."], sq),
        Case("ros", "convert good", ["convert", "m.json", "m.wkt"], sq, allow=(0,),
             outputs=("m.wkt",)),
        Case("ros", "convert bad yaml", ["convert", "r.yaml", "m.json"], yaml_bad),
        Case("ros", "convert yaml garbage", ["convert", "g.yaml", "m.json"],
             {"g.yaml": b"\x00\x01 not yaml: [", "m.json": js(SQUARE)}),
        Case("ros", "sweep --workers 0", ["sweep", "m.json", "--lss", "1", "--workers", "0"],
             sq),
        Case("ros", "sweep bad range", ["sweep", "m.json", "--lss", "1:0:1"], sq),
        Case("ros", "sweep nan range", ["sweep", "m.json", "--lss", "nan"], sq, allow=(0, 2)),
        Case("ros", "sweep --plot missing folder",
             ["sweep", "m.json", "--lss", "1", "--plot", "nope/f.png"], sq),
        Case("ros", "sweep --plot empty", ["sweep", "m.json", "--lss", "1", "--plot", ""], sq),
        Case("ros", "sweep huge range", ["sweep", "m.json", "--lss", "0:1e9:1"], sq),
        Case("ros", "sweep lss 1e-12", ["sweep", "m.json", "--lss", "1e-12"], sq, allow=(0, 2)),
    ]


def usage_cases() -> list[Case]:
    return [
        Case("usage", "no arguments", []),
        Case("usage", "unknown command", ["frobnicate"]),
        Case("usage", "unknown option", ["info", "m.json", "--bogus"], {"m.json": js(SQUARE)}),
        Case("usage", "--version", ["--version"], allow=(0,)),
        Case("usage", "missing --lss", ["decompose", "m.json"], {"m.json": js(SQUARE)}),
        Case("usage", "bad kind", ["plot-motion", "spiral", "--out", "f.png"]),
    ]


def all_cases() -> list[Case]:
    return (encoding_cases() + json_syntax_cases() + json_type_cases() + geometry_cases()
            + geojson_cases() + wkt_cases() + file_cases() + param_cases() + output_cases()
            + usage_cases() + _if_command("convert", ros_cases))


def _if_command(name: str, make) -> list[Case]:
    """Cases of a command group that older versions may not have."""
    from tether.cli import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    return make() if name in sub.choices else []


# ---------------------------------------------------------------------- running
class _Timeout(BaseException):
    pass


def _alarm(signum, frame):
    raise _Timeout


def run_case(case: Case) -> tuple[str, int | None, str]:
    """Run one case in a fresh folder; return ``(outcome, exit status, first stderr line)``."""
    from tether.cli import main

    old = os.getcwd()
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        for name, content in case.files.items():
            (folder / name).write_bytes(content)
        if case.setup:
            case.setup(folder)
        before = {p.relative_to(folder) for p in folder.rglob("*")}
        out, err = io.StringIO(), io.StringIO()
        status: int | None
        escaped = False
        os.chdir(folder)
        signal.signal(signal.SIGALRM, _alarm)
        signal.alarm(case.limit)
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                try:
                    status = main(case.argv)
                except SystemExit as exc:
                    status = exc.code if isinstance(exc.code, int) else 2
        except _Timeout:
            return TIMEOUT, None, ""
        except BaseException as exc:  # noqa: BLE001 - an escaped exception is the finding
            escaped, status = True, None
            err.write(f"Traceback: {type(exc).__name__}: {exc}"[:200] + "\n")
        finally:
            signal.alarm(0)
            os.chdir(old)
        after = {p.relative_to(folder) for p in folder.rglob("*")}
        new = {str(p) for p in after - before}
        lines = [ln for ln in err.getvalue().splitlines() if ln.strip()]
        first = lines[0] if lines else ""
        if escaped or "Traceback" in err.getvalue():
            return TRACE, status, first
        if status == 3:
            return INTERNAL, status, first
        if status not in case.allow and not (status == 1 and case.argv[:1] == ["check"]
                                             and 0 in case.allow):
            return WRONG, status, first
        if new - set(case.outputs) - {"tether-demo"} or (status != 0 and new):
            return LEFT, status, f"left {sorted(new)}"
        if status == 2:
            return (CLEAN if len(lines) == 1 else MULTI), status, first
        return OK, status, first


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-v", "--verbose", action="store_true", help="one row per case")
    ap.add_argument("-k", help="only cases whose class or name contains this")
    args = ap.parse_args(argv)
    os.environ.setdefault("MPLBACKEND", "Agg")
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 1000))
    cases = all_cases()
    if args.k:
        cases = [c for c in cases if args.k in c.klass or args.k in c.name]
    table: dict[str, Counter] = defaultdict(Counter)
    bad = []
    t0 = time.perf_counter()
    for case in cases:
        outcome, status, first = run_case(case)
        table[case.klass][outcome] += 1
        if args.verbose:
            print(f"{case.klass:<13} {case.name:<40} {outcome:<12} {status!s:<5} {first[:110]}")
        if outcome not in (OK, CLEAN):
            bad.append((case, outcome, status, first))
    elapsed = time.perf_counter() - t0
    import tether

    print(f"\ntether {getattr(tether, '__version__', '?')} from {Path(tether.__file__).parent}: "
          f"{len(cases)} cases in {elapsed:.1f} s")
    head = f"{'class':<14}" + "".join(f"{o:>12}" for o in OUTCOMES) + f"{'total':>8}"
    print(head)
    print("-" * len(head))
    total: Counter = Counter()
    for klass, counts in table.items():
        total.update(counts)
        print(f"{klass:<14}" + "".join(f"{counts[o]:>12}" for o in OUTCOMES)
              + f"{sum(counts.values()):>8}")
    print("-" * len(head))
    print(f"{'all':<14}" + "".join(f"{total[o]:>12}" for o in OUTCOMES)
          + f"{sum(total.values()):>8}")
    if bad:
        print("\nnot ok / not a clean error:")
        for case, outcome, status, first in bad:
            print(f"  [{outcome}] {case.klass}: {case.name} (exit {status}): {first[:140]}")
    return len(bad)


if __name__ == "__main__":
    sys.exit(min(main(), 125))
