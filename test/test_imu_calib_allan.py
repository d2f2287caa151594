"""imu_calib.allan: overlapping/non-overlapping Allan deviation, grids, intervals, PSD, real published curve."""
import allantools
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import shared_data
from imu_calib.allan import (AllanError, chi2_interval, log_taus, nonoverlapping_adev, octave_taus,
                             overlapping_adev, psd)
from nav_core.datasets import load_adis_npz
from nav_core.units import DEG, G0


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(20, 3000), rate=st.sampled_from([1.0, 64.0, 100.0]),
       offset=st.floats(-1e3, 1e3))
def test_overlapping_adev_equals_allantools_oadev(seed, n, rate, offset):
    x = np.random.default_rng(seed).standard_normal(n) + offset
    taus = octave_taus(n, rate)
    ours = overlapping_adev(x, rate, taus)
    _, ref, _, _ = allantools.oadev(x, rate=rate, data_type="freq", taus=taus)
    np.testing.assert_allclose(ours.adev, ref, rtol=1e-9)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(16, 2000), shift=st.floats(-1e6, 1e6))
def test_adev_is_invariant_to_a_constant_offset(seed, n, shift):
    x = np.random.default_rng(seed).standard_normal(n)
    a = overlapping_adev(x, 10.0).adev
    b = overlapping_adev(x + shift, 10.0).adev
    np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-12)


def test_nonoverlapping_matches_hand_computed_eqs_8_9():
    x = np.array([1.0, 3.0, 2.0, 6.0, 4.0, 4.0, 0.0, 2.0])
    res = nonoverlapping_adev(x, 1.0, [1.0, 2.0])
    # m = 2: cluster means 2, 4, 4, 1 -> diffs 2, 0, -3 -> avar = (4 + 0 + 9) / (2 * 3)
    np.testing.assert_allclose(res.adev[1] ** 2, 13.0 / 6.0)
    np.testing.assert_allclose(res.adev[0] ** 2, np.mean(np.diff(x) ** 2) / 2.0)
    np.testing.assert_allclose(res.edf, [7.0, 3.0])


def test_white_noise_adev_follows_n_over_sqrt_tau_and_intervals_cover_it():
    rate, n_coef = 50.0, 2e-3
    x = np.random.default_rng(3).standard_normal(200_000) * n_coef * np.sqrt(rate)
    res = overlapping_adev(x, rate)
    truth = n_coef / np.sqrt(res.taus)
    inside = (res.lo <= truth) & (truth <= res.hi)
    assert inside.mean() >= 0.85
    np.testing.assert_allclose(res.adev[:8], truth[:8], rtol=0.05)


def test_multi_axis_result_equals_per_axis_results():
    x = np.random.default_rng(1).standard_normal((5000, 3))
    both = overlapping_adev(x, 20.0)
    for i in range(3):
        np.testing.assert_allclose(both.axis(i).adev, overlapping_adev(x[:, i], 20.0).adev)


def test_octave_and_log_grids_stay_within_the_record():
    n, rate = 10_000, 100.0
    octave = octave_taus(n, rate)
    np.testing.assert_allclose(octave[:3], [0.01, 0.02, 0.04])
    assert octave[-1] * rate <= n // 2 < 2 * octave[-1] * rate
    dense = log_taus(n, rate, per_decade=20)
    assert len(dense) > 2 * len(octave)
    assert np.all(np.diff(dense) > 0) and dense[-1] * rate <= n // 2


def test_too_short_recording_raises_a_clear_message_not_nan():
    x = np.zeros(100)
    with pytest.raises(AllanError, match="recording too short.*100 samples"):
        overlapping_adev(x, 10.0, [1.0, 10.0])


def test_chi2_interval_brackets_the_estimate_and_narrows_with_edf():
    lo1, hi1 = chi2_interval(1.0, 5.0)
    lo2, hi2 = chi2_interval(1.0, 500.0)
    assert lo1 < lo2 < 1.0 < hi2 < hi1


def test_psd_white_level_recovers_white_noise_density():
    rate, n_coef = 100.0, 3e-3
    x = np.random.default_rng(5).standard_normal((100_000, 2)) * n_coef * np.sqrt(rate)
    np.testing.assert_allclose(psd(x, rate).white_noise, n_coef, rtol=0.03)


def test_adis16405_adev_matches_published_avar_curve_within_1_percent():
    rec = load_adis_npz(shared_data("adis16405_static", "imu1.npz"))
    published = np.loadtxt(shared_data("adis16405_static", "published_adev_imu1.csv"), delimiter=",", skiprows=1)
    taus = published[:, 0]
    ours = overlapping_adev(np.column_stack([rec.gyro / DEG, rec.accel / G0]), 100.0, taus)
    np.testing.assert_allclose(ours.taus, taus)
    np.testing.assert_allclose(ours.adev, published[:, 1:], rtol=0.01)
