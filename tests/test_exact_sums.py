"""A streamed mean does not depend on where the run's chunks were cut. Chunks follow wall time
(FLUSH_AFTER_S), so a busy machine cuts them elsewhere; a campaign's `--case N` must still
give its row bit for bit. The oracle is math.fsum over every value at once (correctly rounded),
a second method that keeps no state between chunks."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings, strategies as st

from testbed.recording.recorder import Chunk
from testbed.recording.reductions import Mean

# wide exponents, so that a sum rounded once per chunk loses what a later chunk would keep
value = st.one_of(st.floats(-1e3, 1e3), st.floats(-1e-12, 1e-12), st.floats(-1e150, 1e150))


def _rows(chunk):
    return chunk["v"]


MEAN = Mean(_rows)


def _streamed(values: np.ndarray, cuts: list[int]) -> np.ndarray:
    state = MEAN.start()
    edges = [0, *sorted(set(cuts)), len(values)]
    for lo, hi in zip(edges, edges[1:]):
        state = MEAN.update(state, Chunk(lo, np.arange(lo, hi, dtype=float), {"v": values[lo:hi]}))
    return MEAN.result(state)


@settings(max_examples=300, deadline=None)
@given(data=st.data(), n=st.integers(1, 60))
def test_a_mean_is_the_same_however_the_run_is_cut(data, n):
    values = np.array(data.draw(st.lists(st.tuples(value, value), min_size=n, max_size=n)))
    cuts = data.draw(st.lists(st.integers(1, n), max_size=8))
    streamed = _streamed(values, cuts)
    # exact: both are the correctly rounded sum of the same floats, divided by the same n
    oracle = np.array([math.fsum(values[:, j]) for j in range(2)]) / n
    assert np.array_equal(streamed, oracle)
    assert np.array_equal(streamed, _streamed(values, []))


def test_a_sum_rounded_once_a_chunk_would_lose_the_small_terms():
    """1 + 1e-16 + 1e-16: each 1e-16 alone is below half an ulp of 1, their sum is not."""
    values = np.array([[1.0], [1e-16], [1e-16]])
    assert _streamed(values, [1, 2])[0] * 3 == _streamed(values, [])[0] * 3 == math.fsum([1.0, 2e-16])
    assert math.fsum([1.0, 2e-16]) > 1.0


def test_non_finite_values_give_what_np_mean_gives():
    for column, expected in (([1.0, math.inf], math.inf), ([math.inf, -math.inf], math.nan),
                             ([1.0, math.nan], math.nan), ([1e308, 1e308], math.inf)):
        got = _streamed(np.array(column)[:, None], [1])[0]
        assert got == expected or (math.isnan(expected) and math.isnan(got))
