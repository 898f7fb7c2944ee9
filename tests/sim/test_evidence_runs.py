"""``docs/evidence_runs.py``'s bookkeeping: shards read back (duplicates and a line cut short
by a kill), the runs left to do on resuming, and the summary's counts and replay commands."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[2] / "docs"


@pytest.fixture(scope="module")
def ev(doc_script):
    return doc_script("evidence_runs")


def _rec(field: str, i: int, kind: str, outcome: str = "held", outside: int = 0) -> dict:
    return {"field": field, "i": i, "kind": kind, "start": [1.5, 2.25, 0.125], "seed": i,
            "outcome": outcome, "lost_at": None if outcome == "held" else 3.2,
            "reason": None if outcome == "held" else "rod occluded by V3",
            "outside": outside, "min_margin": 0.01, "steps": 750, "max_speed_ratio": 0.3,
            "cpu_s": 0.5, "wall_s": 0.6}


def test_shards_resume_and_summary(ev, tmp_path):
    f = "nonconvex_corner:0.3:0.25"
    (tmp_path / "runs-a.jsonl").write_text(
        "".join(json.dumps(_rec(f, i, ev.KINDS[i % 7])) + "\n" for i in range(3)))
    lost = _rec(f, 3, ev.KINDS[3], "lost")
    (tmp_path / "runs-b.jsonl").write_text(
        json.dumps(_rec(f, 1, ev.KINDS[1])) + "\n"  # a duplicate: the first one is kept
        + json.dumps(lost) + "\n" + json.dumps(_rec(f, 4, ev.KINDS[4]))[:40])  # cut short
    records, bad = ev.read_shards(tmp_path)
    assert bad == 1
    assert sorted(r["i"] for r in records) == [0, 1, 2, 3]
    done = {(r["field"], r["i"]) for r in records}
    other = "gallery:0.3:0.25"
    assert ev.tasks([f, other], 5, done) == [(other, 0), (other, 1), (other, 2), (other, 3),
                                             (f, 4), (other, 4)]
    text = ev.summary(records, bad, tmp_path)
    assert "4 runs, 1 lost or outside (1 unreadable lines skipped)" in text
    assert "| **all** |  |  |  | **all** | 4 | 1 | 0 |" in text
    assert f"--replay {f}:3" in text
    assert "--target random --start 1.5 2.25 0.125 --seed 3" in text
    assert f"--kernel {ev.field_file(tmp_path, f)}" in text


def test_bad_field_name_is_one_line(ev):
    with pytest.raises(SystemExit, match="a field is MAP:RATIO:H"):
        ev.parse_field("gallery:0.3")


def test_the_table_goes_between_the_markers_and_nowhere_else(ev, tmp_path):
    doc = tmp_path / "doc.md"
    doc.write_text(f"intro\n{ev.BEGIN}\nold table\n{ev.END}\nafter\n")
    ev.write_doc(doc, "| new |\n")
    assert doc.read_text() == f"intro\n{ev.BEGIN}\n| new |\n{ev.END}\nafter\n"
    plain = tmp_path / "plain.md"
    plain.write_text("no markers\n")
    with pytest.raises(SystemExit, match="markers"):
        ev.write_doc(plain, "| new |\n")
    assert plain.read_text() == "no markers\n"


def test_the_docs_table_counts_the_shards(ev):
    """The table in docs/certified.md is what the committed shards say (regenerate with
    ``python docs/evidence_runs.py --summary --doc docs/certified.md``)."""
    records, bad = ev.read_shards(DOCS / "evidence")
    table = ev.summary(records, bad, DOCS / "evidence")
    text = (DOCS / "certified.md").read_text()
    assert table.rstrip() in text


def test_field_keys_floor_plans_radial_lss_and_files(ev):
    s = ev.parse_field("floor_plan:20:0:0.3:0.1:0.2")
    assert (s.name, s.ratio, s.h, s.lss, s.radial, s.bundled) == (
        "floor_plan:20:0", 0.3, 0.1, 0.2, False, False)
    assert s.env().name == "plan-20-0"
    s = ev.parse_field("radial:nonconvex_corner:0.9:0.075:0.15")
    assert (s.name, s.ratio, s.h, s.lss, s.radial, s.bundled) == (
        "nonconvex_corner", 0.9, 0.075, 0.15, True, True)
    s = ev.parse_field("gallery:0.3:0.25")  # the old keys keep their meaning
    assert (s.name, s.ratio, s.h, s.lss, s.radial) == ("gallery", 0.3, 0.25, 1.0, False)
    assert ev.parse_field("file:office_0.3").external
    for bad in ("floor_plan:x:0:0.3:0.1", "floor_plan:20:0:0.3", "radial:gallery:0.3",
                "gallery:0.3:0.25:1:2", "file:", "file:a/b"):
        with pytest.raises(SystemExit, match="evidence_runs: a (file )?field is"):
            ev.parse_field(bad)
    with pytest.raises(SystemExit, match="--field-file"):
        ev.compute_field(ev.parse_field("file:missing"))


def test_summary_of_a_floor_plan_and_a_file_field(ev, tmp_path):
    plan, office = "floor_plan:20:0:0.3:0.1:0.2", "file:office_0.3"
    records = [_rec(plan, 0, ev.KINDS[0], "lost"), _rec(office, 1, ev.KINDS[1])]
    text = ev.summary(records, 0, tmp_path)
    assert "| floor_plan:20:0 | 0.3 | 0.2 | 0.1 | " in text
    assert f"| `{office}` |  |  |  | " in text
    assert f"--replay {plan}:0" in text
    assert "tether simulate" not in text  # a generated map: the script's replay only
