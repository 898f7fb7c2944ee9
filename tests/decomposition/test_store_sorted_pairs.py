"""The store's structure pairs sorted within each structure by one integer key
(:func:`tether.decomposition.store._sorted_pairs`): the order of ``np.lexsort``."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from tether.decomposition.store import _sorted_pairs


def _lexsorted(a, b, size):
    run = np.repeat(np.arange(len(size)), size)
    order = np.lexsort((b, a, run))
    return a[order], b[order]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(0, 6), min_size=0, max_size=12), st.integers(1, 9),
       st.booleans(), st.integers(0, 2**32 - 1))
def test_sorted_pairs_is_lexsort(sizes, base, presorted, seed):
    rng = np.random.default_rng(seed)
    size = np.asarray(sizes, np.int64)
    n = int(size.sum())
    a, b = rng.integers(0, base, n), rng.integers(0, base, n)  # repeats included
    if presorted:
        a, b = _lexsorted(a, b, size)
    got, want = _sorted_pairs(a, b, size, base), _lexsorted(a, b, size)
    assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])


def test_sorted_pairs_past_63_bits_falls_back_to_lexsort():
    base = 2**31  # (runs + 1) * base**2 overflows: the lexsort
    a = np.array([5, 2, 2**31 - 1, 0], np.int64)
    b = np.array([1, 9, 3, 2**31 - 2], np.int64)
    size = np.array([3, 1])
    got = _sorted_pairs(a, b, size, base)
    assert got[0].tolist() == [2, 5, 2**31 - 1, 0]
    assert got[1].tolist() == [9, 1, 3, 2**31 - 2]
