"""Work on several cores, in threads. shapely's vectorized functions and numpy's calls on large
arrays release the GIL, so the chunks of one array of geometries (:func:`map_chunks`), the
independent batches of a vectorized computation (:func:`map_batches`) and work overlapped with
a long GEOS call (:func:`in_background`) give the same results, bit for bit, in less wall time.

``TETHER_THREADS`` sets the number of threads (``1`` turns threading off, e.g. inside worker
processes of a sweep that already use every core); by default, the cores this process may use.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any, TypeVar

import numpy as np

__all__ = [
    "MIN_CHUNKED", "THREADS_ENV", "in_background", "map_batches", "map_chunks", "single_threaded",
    "thread_count"
]

T = TypeVar("T")

#: The environment variable giving the number of threads (a positive integer).
THREADS_ENV = "TETHER_THREADS"

#: Arrays shorter than this run in the calling thread (a thread's start-up costs more).
MIN_CHUNKED = 64


def thread_count() -> int:
    """Threads for element-wise calls: ``TETHER_THREADS`` if it is a positive integer, else the
    number of cores this process may run on."""
    got = os.environ.get(THREADS_ENV, "").strip()
    if got.isdigit() and int(got) > 0:
        return int(got)
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def map_chunks(func: Callable[..., np.ndarray], items: np.ndarray, **kwargs: Any
               ) -> np.ndarray:
    """``func(items, **kwargs)`` for an element-wise ``func`` (one output row per item),
    computed on chunks of ``items`` in threads and concatenated in order. Four chunks per
    thread, so that a few costly items do not leave a thread idle."""
    n = thread_count()
    if n <= 1 or len(items) < MIN_CHUNKED:
        return func(items, **kwargs)
    chunks = np.array_split(items, min(4 * n, len(items)))
    with ThreadPoolExecutor(max_workers=n) as pool:
        parts = list(pool.map(lambda chunk: func(chunk, **kwargs), chunks))
    return np.concatenate(parts)


def in_background(func: Callable[..., T], *args: Any) -> Callable[[], T]:
    """Start ``func(*args)`` in a thread now and return a function giving its value (raising
    its exception), waiting for it if need be: work overlapped with a long call that releases
    the GIL (e.g. GEOS's noding). With one thread (``TETHER_THREADS=1``) ``func`` runs when
    its value is first asked for."""
    if thread_count() <= 1:
        done: list = []

        def inline() -> T:
            if not done:
                done.append(func(*args))
            return done[0]
        return inline
    pool = ThreadPoolExecutor(max_workers=1)
    future = pool.submit(func, *args)
    pool.shutdown(wait=False)  # the thread ends with its one task
    return future.result


def map_batches(func: Callable[[int, int], T], count: int, batch: int) -> list[T]:
    """``[func(lo, hi) for each batch lo:hi of range(count)]``, batches of ``batch`` items,
    in order: for work whose numpy and shapely calls on large arrays release the GIL. The
    first batch runs in the calling thread (it builds what the batches share and cache: edge
    grids, the map's prepared polygon and its point locator, which GEOS builds lazily and not
    thread-safely), the others in threads, at most ``thread_count()`` at a time."""
    spans = [(lo, min(lo + batch, count)) for lo in range(0, count, batch)]
    n = min(thread_count(), len(spans) - 1)
    if n <= 1:
        return [func(lo, hi) for lo, hi in spans]
    first = func(*spans[0])
    with ThreadPoolExecutor(max_workers=n) as pool:
        return [first, *pool.map(lambda span: func(*span), spans[1:])]


def single_threaded() -> None:
    """Run element-wise calls in the calling thread from now on, unless ``TETHER_THREADS`` is
    set already: the initializer of a sweep's worker processes, which fill the cores."""
    os.environ.setdefault(THREADS_ENV, "1")
