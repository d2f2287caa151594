"""imu_calib.allan kernels: the blocked second-difference pass equals a plain NumPy computation."""
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from imu_calib.allan import (SECOND_DIFFERENCE_BLOCK, _nonoverlapping_second_difference_means, _phase_into,
                             _second_difference_means)


def _numpy_means(theta, ms):
    """Mean of (theta[k+2m] - 2 theta[k+m] + theta[k])^2 over every k, one m at a time."""
    n1 = len(theta)
    return np.array([np.mean((theta[2 * m:] - 2 * theta[m:n1 - m] + theta[:n1 - 2 * m]) ** 2) for m in ms])


def _random_phase(seed, n):
    rng = np.random.default_rng(seed)
    theta = np.empty(n + 1)
    # white noise plus a random walk, so the second differences span several orders of magnitude over m
    _phase_into(rng.standard_normal(n) + np.cumsum(rng.standard_normal(n)) * 1e-2, 0.3, 0.01, theta)
    return theta


@st.composite
def _record_and_grid(draw):
    """A record length, a block size, and cluster sizes that include m near the block and 2m near n."""
    n = draw(st.integers(3, 4000))
    block = draw(st.one_of(st.integers(1, 70), st.integers(n // 4 + 1, n + 10)))
    m_max = (n - 1) // 2
    near = [m_max, m_max - 1, n // 2 - 1, block - 1, block, block + 1, block // 2, (block + 1) // 2]
    ms = [m for m in near if 1 <= m <= m_max]
    ms += draw(st.lists(st.integers(1, m_max), max_size=12))
    return n, block, draw(st.permutations(ms))


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), case=_record_and_grid())
def test_blocked_second_difference_kernel_equals_numpy_for_any_length_block_and_cluster_sizes(seed, case):
    n, block, ms = case
    theta = _random_phase(seed, n)
    ms = np.array(ms, dtype=np.int64)
    ours = _second_difference_means(theta, ms, block)
    np.testing.assert_allclose(ours, _numpy_means(theta, ms), rtol=1e-12)


def test_blocked_kernel_with_the_default_block_equals_numpy_across_block_boundaries():
    n = 3 * SECOND_DIFFERENCE_BLOCK + 123
    theta = _random_phase(7, n)
    b = SECOND_DIFFERENCE_BLOCK
    ms = np.array([1, 2, 3, b // 2 - 1, b // 2, b // 2 + 1, b - 1, b, b + 1, b + b // 4, (n - 1) // 2], np.int64)
    np.testing.assert_allclose(_second_difference_means(theta, ms), _numpy_means(theta, ms), rtol=1e-12)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 3000), data=st.data())
def test_nonoverlapping_kernel_equals_cluster_means_eqs_8_9(seed, n, data):
    theta = _random_phase(seed, n)
    ms = np.array(data.draw(st.lists(st.integers(1, (n - 1) // 2), min_size=1, max_size=8)), dtype=np.int64)
    # eqs. 8-9 on the phase: cluster sums are diff(theta[::m]); half the mean squared difference of neighbours
    expected = [np.mean(np.diff(np.diff(theta[::m])) ** 2) for m in ms]
    np.testing.assert_allclose(_nonoverlapping_second_difference_means(theta, ms), expected, rtol=1e-12)
