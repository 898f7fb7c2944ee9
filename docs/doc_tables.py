"""Rewrite a generated table in a doc: the text between two HTML-comment markers, shared by the
table scripts next to this file (``band_table``, ``certified_table``, ``delay_table``,
``fractions_table``)."""

from __future__ import annotations

from pathlib import Path


def replace_between(text: str, begin: str, end: str, body: str) -> str:
    """``text`` with everything between the first ``begin`` and the next ``end`` replaced by
    ``body`` on its own lines. Raises SystemExit (one line) when a marker is missing."""
    if begin not in text or end not in text.split(begin, 1)[1]:
        raise SystemExit(f"no {begin} ... {end} markers")
    head, rest = text.split(begin, 1)
    return f"{head}{begin}\n{body.rstrip()}\n{end}{rest.split(end, 1)[1]}"


def write_between(doc: Path, begin: str, end: str, body: str) -> None:
    """Replace the table between ``doc``'s markers by ``body`` (written to a temporary file
    and moved into place, so a failure leaves the doc as it was)."""
    try:
        new = replace_between(doc.read_text(), begin, end, body)
    except SystemExit as e:
        raise SystemExit(f"{doc}: {e}") from None
    tmp = doc.with_suffix(doc.suffix + ".tmp")
    tmp.write_text(new)
    tmp.replace(doc)
