"""The memory budget (sizes, its sources) and the decomposition's memory estimate: refused
before the expensive stage, in one line, with what would fit."""

import os
import re
import time

import numpy as np
import pytest
from conftest import GENERIC, L_SHAPE, SQUARE_HOLE
from hypothesis import given, settings
from hypothesis import strategies as st

import tether._util.memory as M
import tether.curves as C
from tether.cli import main
from tether.curves.budget import check_memory, estimate_memory
from tether.decomposition import decompose
from tether.errors import InvalidParameterError, ResourceLimitError
from tether.examples import path as example_path


# ------------------------------------------------------------------------- sizes
@pytest.mark.parametrize(("text", "expected"), [
    ("8G", 8 << 30), ("500M", 500 << 20), ("500m", 500 << 20), ("1.5G", 3 << 29),
    ("2KB", 2048), ("2KiB", 2048), ("4 GB", 4 << 30), ("1T", 1 << 40), ("1048576", 1 << 20),
    ("1e6", 1_000_000), (" 3M ", 3 << 20),
])
def test_parse_size(text, expected):
    assert M.parse_size(text) == expected


@pytest.mark.parametrize("text", ["", "G", "8X", "-1G", "8GG", "1.2.3M", "nan", "inf", "100",
                                  "0M", "eight gigs"])
def test_parse_size_refuses(text):
    with pytest.raises(InvalidParameterError, match="memory size"):
        M.parse_size(text)


@settings(max_examples=25)
@given(st.integers(1, 1 << 20), st.sampled_from(["K", "M", "G"]))
def test_parse_size_units_are_powers_of_1024(value, unit):
    scale = {"K": 1 << 10, "M": 1 << 20, "G": 1 << 30}[unit]
    assert M.parse_size(f"{value}{unit}") == value * scale
    assert M.parse_size(f"{value}{unit.lower()}b") == value * scale


# ------------------------------------------------------------------------- sources
def _fake_machine(monkeypatch, tmp_path, available_kb=None, rss_kb=0, cgroup=None,
                  cgroup_v1=None, rlimit=None):
    """Point the budget's files at ``tmp_path`` (None: the file is missing)."""
    meminfo = tmp_path / "meminfo"
    if available_kb is not None:
        meminfo.write_text(f"MemTotal:  99999999 kB\nMemAvailable:  {available_kb} kB\n")
    status = tmp_path / "status"
    status.write_text(f"Name: python\nVmRSS:\t  {rss_kb} kB\n")
    v2, v1 = tmp_path / "memory.max", tmp_path / "memory.limit_in_bytes"
    if cgroup is not None:
        v2.write_text(f"{cgroup}\n")
    if cgroup_v1 is not None:
        v1.write_text(f"{cgroup_v1}\n")
    monkeypatch.setattr(M, "MEMINFO", meminfo)
    monkeypatch.setattr(M, "STATUS", status)
    monkeypatch.setattr(M, "CGROUP_FILES", (v2, v1))
    monkeypatch.setattr(M, "_rlimit_as", lambda: rlimit)
    monkeypatch.delenv(M.ENV_VAR, raising=False)


def test_budget_is_the_smallest_source(monkeypatch, tmp_path):
    _fake_machine(monkeypatch, tmp_path, available_kb=4 << 20, rss_kb=1 << 20,
                  cgroup=str(8 << 30), rlimit=16 << 30)
    assert M.memory_budget() == M.MemoryBudget(5 << 30, "available memory")  # 4 G + own 1 G
    _fake_machine(monkeypatch, tmp_path, available_kb=4 << 20, cgroup=str(2 << 30),
                  rlimit=16 << 30)
    assert M.memory_budget() == M.MemoryBudget(2 << 30, "cgroup limit")
    _fake_machine(monkeypatch, tmp_path, available_kb=4 << 20, cgroup="max", rlimit=1 << 30)
    assert M.memory_budget() == M.MemoryBudget(1 << 30, "RLIMIT_AS")


def test_budget_cgroup_v1_and_unlimited_values(monkeypatch, tmp_path):
    _fake_machine(monkeypatch, tmp_path, available_kb=64 << 20, cgroup_v1=str(3 << 30))
    assert M.memory_budget() == M.MemoryBudget(3 << 30, "cgroup limit")
    _fake_machine(monkeypatch, tmp_path, available_kb=64 << 20, cgroup_v1="9223372036854771712")
    assert M.memory_budget().source == "available memory"  # v1's "no limit"
    _fake_machine(monkeypatch, tmp_path, available_kb=64 << 20, cgroup="max",
                  cgroup_v1=str(1 << 30))
    assert M.memory_budget().source == "available memory"  # v2 says "max": v1 not read


def test_budget_without_sources_is_unbounded(monkeypatch, tmp_path):
    _fake_machine(monkeypatch, tmp_path)
    assert M.memory_budget() == M.MemoryBudget(None, "none")
    check_memory(GENERIC, 3.0)  # nothing to refuse against


def test_env_var_overrides_the_machine(monkeypatch, tmp_path):
    _fake_machine(monkeypatch, tmp_path, available_kb=1 << 10)
    monkeypatch.setenv(M.ENV_VAR, "8G")
    assert M.memory_budget() == M.MemoryBudget(8 << 30, M.ENV_VAR)
    monkeypatch.setenv(M.ENV_VAR, "lots")
    with pytest.raises(InvalidParameterError, match=M.ENV_VAR):
        M.memory_budget()


def test_memory_limit_block_sets_and_restores(monkeypatch):
    monkeypatch.setenv(M.ENV_VAR, "1G")
    with M.memory_limit("300M"):
        assert M.memory_budget().bytes == 300 << 20
        with M.memory_limit(None):
            assert os.environ[M.ENV_VAR] == str(300 << 20)
    assert os.environ[M.ENV_VAR] == "1G"
    monkeypatch.delenv(M.ENV_VAR)
    with M.memory_limit(1 << 30):
        assert M.memory_budget().bytes == 1 << 30
    assert M.ENV_VAR not in os.environ


def test_this_machine_has_a_budget():
    limits = M.machine_limits()
    assert set(limits) == {"available memory", "cgroup limit", "RLIMIT_AS"}
    got = [v for v in limits.values() if v is not None]
    assert all(v > 0 for v in got)


# ------------------------------------------------------------------------- the estimate
@settings(max_examples=12, deadline=None)
@given(st.floats(0.2, 6.0), st.floats(1.01, 3.0))
def test_estimate_grows_with_lss(lss, factor):
    a, b = estimate_memory(SQUARE_HOLE, lss), estimate_memory(SQUARE_HOLE, lss * factor)
    assert a.pairs <= b.pairs and a.step > b.step and a.bytes < b.bytes


@settings(max_examples=12, deadline=None)
@given(st.floats(1e-7, 1e-4), st.floats(1.01, 10.0))
def test_estimate_shrinks_with_a_coarser_tolerance(tol, factor):
    a, b = estimate_memory(GENERIC, 2.0, tol), estimate_memory(GENERIC, 2.0, tol * factor)
    assert a.pairs == b.pairs and a.bytes > b.bytes


def test_pairs_are_the_vertex_edge_pairs_within_lss():
    # brute force: every (vertex, edge) distance
    env = GENERIC
    a, b, _, _ = env.oriented_edges
    p = env.vertices[:, None, :]
    d = b - a
    t = np.clip(((p - a) * d).sum(-1) / (d * d).sum(-1), 0, 1)
    dist = np.hypot(*np.moveaxis(a + t[..., None] * d - p, -1, 0))
    for lss in (0.5, 1.7, 4.0):
        assert estimate_memory(env, lss).pairs == int(np.sum(dist < lss))


def test_estimate_is_the_same_in_any_frame():
    # the estimate is unit-free: a map scaled by 1000 gives the same numbers at 1000 lss
    from tether import Environment

    big = Environment(L_SHAPE.boundary * 1000.0)
    a, b = estimate_memory(L_SHAPE, 2.0), estimate_memory(big, 2000.0)
    assert a.pairs == b.pairs and a.bytes == pytest.approx(b.bytes, rel=1e-9)


# ------------------------------------------------------------------------- refusals
def test_refusal_comes_before_any_curve(monkeypatch):
    import tether.decomposition.pipeline as P

    def never(*args, **kw):
        raise AssertionError("the curves were computed")

    monkeypatch.setattr(P, "critical_curves", never)
    monkeypatch.setenv(M.ENV_VAR, "10M")
    with pytest.raises(ResourceLimitError) as info:
        decompose(GENERIC, 3.0)
    msg = str(info.value)
    assert "\n" not in msg and "10 MB" in msg and "--memory-limit" in msg
    assert "what would fit" in msg


def test_refusal_names_an_lss_and_a_tolerance_that_fit(monkeypatch):
    env, lss = SQUARE_HOLE, 3.0
    need = estimate_memory(env, lss).bytes
    budget = int(0.5 * (need + C.budget.BASE_BYTES))  # room for half the size
    monkeypatch.setenv(M.ENV_VAR, str(budget))
    with pytest.raises(ResourceLimitError) as info:
        check_memory(env, lss)
    msg = str(info.value)
    fit_lss = float(re.search(r"lss <= ([0-9.e+-]+)", msg).group(1))
    fit_tol = float(re.search(r"rel_tol >= ([0-9.e+-]+)", msg).group(1))
    assert fit_lss < lss and estimate_memory(env, fit_lss).bytes <= budget
    assert estimate_memory(env, fit_lss * 1.01).bytes > budget * 0.99  # the largest, nearly
    assert estimate_memory(env, lss, fit_tol).bytes <= budget * 1.01  # rounded to 2 digits
    check_memory(env, fit_lss)  # fits
    check_memory(env, lss, fit_tol * 1.05)


def test_cli_refuses_at_once_in_one_line(capsys):
    t0 = time.perf_counter()
    code = main(["analyze", str(example_path("gallery")), "--lss", "2", "--memory-limit", "20M"])
    elapsed = time.perf_counter() - t0
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert err[0].startswith("tether: error: map 'gallery' at lss 2 would need about")
    assert "more than the budget 20 MB" in err[0]
    assert elapsed < 5.0, elapsed  # milliseconds of work; a generous bound on a busy machine
    assert M.ENV_VAR not in os.environ  # the limit was for that command only


def test_cli_bad_size_is_a_usage_error(capsys):
    assert main(["decompose", str(example_path("gallery")), "--lss", "2", "--memory-limit",
                 "8X"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--memory-limit" in err[0] and "8X" in err[0]


def test_a_generous_limit_changes_nothing(capsys):
    assert main(["decompose", str(example_path("rectangle")), "--lss", "1",
                 "--memory-limit", "64G"]) == 0
    assert "19 regions, 32 cells" in capsys.readouterr().out


def test_max_curve_vertices_still_refuses_when_set(monkeypatch):
    monkeypatch.setattr(C, "MAX_CURVE_VERTICES", 50)
    with pytest.raises(ResourceLimitError, match="MAX_CURVE_VERTICES"):
        decompose(GENERIC, 3.0)


def test_exact_check_uses_the_budget(monkeypatch):
    from tether.curves.budget import check_exact

    monkeypatch.setenv(M.ENV_VAR, "1G")
    check_exact(GENERIC, 3.0, 1000)
    with pytest.raises(ResourceLimitError, match="budget 1.00 GB"):
        check_exact(GENERIC, 3.0, 1e9)
    C.check_vertex_budget(1e9, 3.0)  # MAX_CURVE_VERTICES unset: no fixed ceiling
