"""The critical intervals of the candidate families made by tasks on an executor (issue 25).

The critical intervals (:func:`tether.curves.critical.critical_intervals`) are most of the
critical curves' time (at 2,000 floor-plan vertices 11 of 14 s, the exact rod tests and the
breakpoints) and they are computed curve by curve: the intervals of a curve depend on that
curve and the map only. So each family is cut into chunks of :data:`CHUNK_CURVES` consecutive
curves, every chunk a task (the map and the chunk's rows: a few MB at most, never the
polylines), and the chunks' intervals are joined in order: the very intervals computed in one
process, bit for bit. The polylines are drawn afterwards in the calling process, as before.
"""

from __future__ import annotations

from collections.abc import Iterator
from concurrent.futures import Executor, Future

import numpy as np

from tether._util.memory import release_memory
from tether.curves.critical import critical_intervals
from tether.curves.families import Family
from tether.environment import Environment

__all__ = ["CHUNK_CURVES", "family_intervals"]

#: Curves per task: at 4,000 floor-plan vertices the line (D) and conchoid (E) families hold
#: ~350,000 and ~190,000 candidates, ~70 tasks of about a second each; a task sends the map
#: (~0.3 MB) and the chunk's rows (~0.7 MB) and returns its intervals.
CHUNK_CURVES = 8192

Intervals = list[list[tuple[float, float]]]


def family_intervals(env: Environment, families: list[Family],
                     executor: Executor | None = None, chunk: int | None = None
                     ) -> Iterator[tuple[Family, Intervals]]:
    """Each family of ``families`` with its critical intervals, in order.

    Parameters
    ----------
    env : Environment
        The internal map.
    families : list of Family
        The candidate families (:func:`tether.curves.families.candidate_families`).
    executor : concurrent.futures.Executor, optional
        Runs the chunks (every chunk of every family submitted at once, results taken in
        order: the caller works on a family while the next ones are computed); None: each
        family in this process, one after the other.
    chunk : int, optional
        Curves per task; by default :data:`CHUNK_CURVES` (read at the call).

    Yields
    ------
    (Family, list of list of (float, float))
        The family and, per curve, its semi-free parameter intervals: the same as
        ``critical_intervals(env, family)``.
    """
    if executor is None:
        for fam in families:
            yield fam, critical_intervals(env, fam)
        return
    step = CHUNK_CURVES if chunk is None else chunk
    pending = [_submit_chunks(executor, env, fam, step) for fam in families]
    for fam, futures in zip(families, pending, strict=True):
        ivs: Intervals = []
        for future in futures:
            ivs += future.result()
        yield fam, ivs


def _submit_chunks(executor: Executor, env: Environment, fam: Family, chunk: int
                   ) -> list[Future]:
    """The tasks computing the intervals of ``fam``'s curves ``chunk`` by ``chunk``."""
    step, m = max(int(chunk), 1), len(fam)
    return [executor.submit(_chunk_intervals, env, fam.rows(np.arange(a, min(a + step, m))))
            for a in range(0, m, step)]


def _chunk_intervals(env: Environment, rows: Family) -> Intervals:
    """The task: ``critical_intervals(env, rows)`` (run in a worker), the C heap's freed
    memory returned to the system before the result is sent (as the tiles' tasks do,
    :func:`tether.decomposition.tiles.trimmed`)."""
    out = critical_intervals(env, rows)
    release_memory()
    return out
