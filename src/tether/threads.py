"""Element-wise work on several cores. shapely's vectorized functions release the GIL, so the
chunks of one array of geometries, run in threads, give the same results (element by element,
bit for bit) in less wall time.

``TETHER_THREADS`` sets the number of threads (``1`` turns threading off, e.g. inside worker
processes of a sweep that already use every core); by default, the cores this process may use.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

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


def single_threaded() -> None:
    """Run element-wise calls in the calling thread from now on, unless ``TETHER_THREADS`` is
    set already: the initializer of a sweep's worker processes, which fill the cores."""
    os.environ.setdefault(THREADS_ENV, "1")
