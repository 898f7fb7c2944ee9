"""Documented console output is the code's output: every ``<!-- checked: tether ... -->`` block
in the README and docs/ must match what the command prints (regenerate with
``python docs/make_docs.py``)."""

import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _make_docs():
    spec = importlib.util.spec_from_file_location("make_docs", ROOT / "docs" / "make_docs.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


make_docs = _make_docs()


@pytest.mark.parametrize("name", make_docs.FILES)
def test_checked_blocks_are_current(name):
    path = ROOT / name
    if not path.exists():
        pytest.skip(f"{name} not present")
    _, stale = make_docs.render(path.read_text())
    assert not stale, f"{name}: stale output of {stale}; run python docs/make_docs.py"


def test_readme_has_checked_blocks():
    text = (ROOT / "README.md").read_text()
    assert len(make_docs.MARKER.findall(text)) >= 2


def test_stale_block_is_detected():
    text = ("<!-- checked: tether --version -->\n```console\n$ tether --version\nold\n```\n")
    new, stale = make_docs.render(text)
    assert stale == ["tether --version"] and "old" not in new
    assert make_docs.render(new)[1] == []


@pytest.mark.parametrize("name", ["gallery", "rectangle", "convex_corner", "nonconvex_corner"])
def test_example_maps_agree_in_every_format(name):
    from tether.examples import path as example_path
    from tether.io import load_map

    ref = load_map(example_path(name)).to_dict()
    for ext in ("wkt", "geojson"):
        other = load_map(example_path(name).with_suffix(f".{ext}")).to_dict()
        assert other == ref
