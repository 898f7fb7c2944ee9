"""``docs/doc_tables.py``: the table between two markers replaced, the text around it kept,
and a missing marker a one-line error that leaves the doc as it was."""

from __future__ import annotations

import pytest

B, E = "<!-- t: begin -->", "<!-- t: end -->"


@pytest.fixture(scope="module")
def dt(doc_script):
    return doc_script("doc_tables")


def test_the_table_between_the_markers_is_replaced(dt):
    text = f"head\n{B}\nold 1\nold 2\n{E}\ntail {B} again\n"
    assert dt.replace_between(text, B, E, "new\n") == f"head\n{B}\nnew\n{E}\ntail {B} again\n"


@pytest.mark.parametrize("text", ["no markers", f"{B} only begin", f"{E} end before {B}"])
def test_a_missing_marker_is_an_error_and_the_doc_is_kept(dt, tmp_path, text):
    doc = tmp_path / "doc.md"
    doc.write_text(text)
    with pytest.raises(SystemExit, match="no <!-- t: begin -->"):
        dt.write_between(doc, B, E, "new")
    assert doc.read_text() == text and sorted(p.name for p in tmp_path.iterdir()) == ["doc.md"]


def test_write_between_rewrites_the_file(dt, tmp_path):
    doc = tmp_path / "doc.md"
    doc.write_text(f"a\n{B}\nx\n{E}\nb\n")
    dt.write_between(doc, B, E, "| y |")
    assert doc.read_text() == f"a\n{B}\n| y |\n{E}\nb\n"
