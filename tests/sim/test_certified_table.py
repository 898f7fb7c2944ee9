"""``docs/certified_table.py``'s bookkeeping: the rows of the table before its ``lss`` column
read back with ``lss`` = 1, rows keyed by map, ratio and rod length, and the rows of saved
fields (``--field-file``) kept when the script's own rows are computed again."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="module")
def ct(doc_script):
    return doc_script("certified_table")


OLD = """x
<!-- certified_table: begin -->
| map | vt/vo | mesh h | certified | certified % | inner kernel % | outer kernel % | seconds | runs from certified starts | lost | states outside |
| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |
| gallery | 0.3 | 0.25 | yes | 91.6 ± 0.1 | 99.8 | 99.9 | 9 | 336 | 0 | 0 |
| gallery | 0.6 | 0.25 | not run (`--skip`) | | | | | | | |
<!-- certified_table: end -->
y"""  # noqa: E501


def test_rows_without_the_lss_column_get_lss_1(ct):
    rows = ct._rows_of(OLD)
    assert list(rows) == [("gallery", 0.3, 1.0), ("gallery", 0.6, 1.0)]
    cells = [c.strip() for c in rows[("gallery", 0.3, 1.0)].strip("|").split("|")]
    assert len(cells) == len(ct.HEADER.strip("|").split("|")) == 12
    assert cells[:4] == ["gallery", "0.3", "1", "0.25"] and cells[-3:] == ["336", "0", "0"]
    assert len(rows[("gallery", 0.6, 1.0)].strip("|").split("|")) == 12


def test_rows_of_the_new_table_read_back_unchanged(ct):
    line = "| gallery | 0.6 | 0.4 | 0.2 refined | yes | 91.8 ± 0.1 | 1 | 2 | 3 | 336 | 0 | 0 |"
    text = f"{ct.BEGIN}\n{ct.HEADER}\n{ct.RULE}\n{line}\n{ct.END}"
    assert ct._rows_of(text) == {("gallery", 0.6, 0.4): line}


def test_a_field_row_is_kept_when_the_script_rows_are_skipped(ct):
    """table() with every computed row skipped or copied: the saved field's row (lss 0.4)
    stays, after the script's rows, and the lss-1 row of the same map and ratio is its own."""
    field = "| gallery | 0.6 | 0.4 | 0.2 refined | yes | 91.8 ± 0.1 | 1 | 2 | 3 | 336 | 0 | 0 |"
    text = OLD.replace("<!-- certified_table: end -->", field + "\n<!-- certified_table: end -->")
    body = ct.table({"gallery": 0.25}, (0.3, 0.6), 0, 1.0, skip=frozenset({("gallery", 0.6)}),
                    only=frozenset({("gallery", 0.9)}), old=text)
    lines = body.splitlines()
    assert lines[0] == ct.HEADER and lines[-1] == field
    assert lines[2].startswith("| gallery | 0.3 | 1 | 0.25 | yes")
    assert lines[3].startswith("| gallery | 0.6 | 1 | 0.25 | not run")
