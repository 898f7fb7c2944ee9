"""The memory estimate of the tiled path (#25): the calling process's peak from the projected
counts and the bytes per object, a worker's from its tile's input segments. A tiled run that
fits is not refused where the untiled one is, and each refusal names what would fit; what it
names is checked to fit by the same check."""

import re

import pytest

from tether._util.memory import memory_limit
from tether.curves.budget import (
    AUTO_PLAN,
    TILED_REFERENCE,
    TilePlan,
    check_memory,
    estimate_memory,
    estimate_tiled,
)
from tether.errors import ResourceLimitError
from tether.examples.floorplan import floor_plan


@pytest.fixture(scope="module")
def plan_map():
    env = floor_plan(600, seed=0)
    return env, (env.bounds[2] - env.bounds[0]) / 15


def _tiled(env, lss, plan=AUTO_PLAN):
    from tether.curves.budget import _tiled

    return _tiled(env, estimate_memory(env, lss), plan)


def test_model_grows_with_the_map_and_tiles_bound_the_worker():
    ref = TILED_REFERENCE
    base = estimate_tiled(ref["n"], ref["pairs"], ref["vertices"], AUTO_PLAN)
    assert all(base.counts[k] == ref[k] for k in ("regions", "pieces", "cells", "edges"))
    more = estimate_tiled(ref["n"], 2 * ref["pairs"], 2 * ref["vertices"], AUTO_PLAN)
    assert more.main > base.main and all(more.counts[k] > base.counts[k] for k in more.counts)
    few = estimate_tiled(ref["n"], ref["pairs"], ref["vertices"], TilePlan(2, 250_000, 64))
    many = estimate_tiled(ref["n"], ref["pairs"], ref["vertices"], TilePlan(16, 250_000, 64))
    assert few.worker > many.worker and few.main == many.main  # tiles: the workers only
    assert AUTO_PLAN.tiles_for(1e9) == 64 and AUTO_PLAN.tiles_for(1) == 1


PLAN16 = TilePlan(16, 250_000, 64)


def test_a_tiled_run_that_fits_is_not_refused(plan_map):
    env, lss = plan_map
    untiled, tiled = estimate_memory(env, lss).bytes, _tiled(env, lss, PLAN16)
    budget = 0.5 * (untiled + max(tiled.main, tiled.worker))
    assert max(tiled.main, tiled.worker) < budget < untiled
    with memory_limit(int(budget)):
        check_memory(env, lss, tiles=PLAN16)  # fits in 16 tiles
        with pytest.raises(ResourceLimitError, match=r"what would fit: .*lss <="):
            check_memory(env, lss)


def test_tiled_refusal_names_an_lss_and_tiles_that_fit(plan_map):
    env, lss = plan_map
    tiled = _tiled(env, lss, PLAN16)
    budget = int(0.9 * tiled.main)  # the calling process does not fit: a shorter lss
    with memory_limit(budget), pytest.raises(ResourceLimitError) as err:
        check_memory(env, lss, tiles=PLAN16)
    msg = str(err.value)
    assert "in 16 tiles would need about" in msg and "\n" not in msg
    shorter = float(re.search(r"lss <= ([0-9.e+-]+)", msg).group(1))
    assert shorter < lss
    with memory_limit(budget):
        check_memory(env, shorter, tiles=PLAN16)
    one = TilePlan(1, 250_000, 64)  # a worker over the budget, this process within it
    tiled = _tiled(env, lss, one)
    budget = int(0.5 * (tiled.main + tiled.worker))
    assert tiled.main < budget < tiled.worker
    with memory_limit(budget), pytest.raises(ResourceLimitError) as err:
        check_memory(env, lss, tiles=one)
    need = int(re.search(r"(\d+) tiles or more", str(err.value)).group(1))
    with memory_limit(budget):
        check_memory(env, lss, tiles=TilePlan(need, 250_000, 64))
