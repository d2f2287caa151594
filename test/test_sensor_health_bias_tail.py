"""The bias CUSUMs' false alarms counted on long simulated window means (sensor_health.bias_tail)."""
import numpy as np

import pytest

from sensor_health.bias_tail import _excursion_maxima, counted_tail, threshold_for


def test_the_counted_excursions_of_a_cusum_on_white_innovations_give_its_known_run_length():
    """k 0.5, h 4 on N(0, 1): one-sided ARL 338 windows (Siegmund), so a two-sided one alarms every ~169."""
    n = 400_000
    maxima = _excursion_maxima(n + 60, 3, 1.0, np.ones(1), np.zeros(0), np.zeros(0), 0.0, 0.0, 0.5, 2.0, 60)
    alarms = np.count_nonzero(maxima > 4.0)
    assert abs(alarms / (n / 169.0) - 1.0) < 0.12


def test_a_slow_wander_the_filter_does_not_follow_raises_the_counted_rate():
    args = (400_000, 4, 1.0, np.ones(1))
    white = _excursion_maxima(*args, np.zeros(0), np.zeros(0), 0.0, 1e-4, 0.5, 2.0, 60)
    phi = np.exp(-1 / 300.0)
    wander = _excursion_maxima(*args, np.array([phi]), np.array([0.3 * np.sqrt(1 - phi**2)]), 0.0, 1e-4, 0.5, 2.0, 60)
    assert np.count_nonzero(wander > 8.0) > 3 * max(np.count_nonzero(white > 8.0), 1)


def test_the_threshold_is_read_off_the_counts_where_they_suffice_and_an_exponential_tail_beyond():
    rng = np.random.default_rng(0)
    maxima = 2.0 + rng.exponential(1.0, 100_000)  # P(max > h) = exp(-(h - 2)): 1e5 excursions in 1000 h
    h, how = threshold_for(maxima, 1000.0, 10.0)  # 1000 alarms allowed: measured
    assert how == "measured" and abs(h - (2.0 + np.log(100.0))) < 0.1
    h, how = threshold_for(maxima, 1000.0, 0.01)  # 1 alarm allowed: extended
    assert how == "extended" and abs(h - (2.0 + np.log(1e5))) < 0.5


def _white(n_phi=0):
    """(white_sd, levels, gm_phi, gm_sd, rw_sd, q): unit white window means, with a slow Gauss-Markov wander the
    filter's walk does not follow where n_phi."""
    phi = np.array([np.exp(-1 / 300.0)] * n_phi)
    return 1.0, np.ones(1), phi, 0.3 * np.sqrt(1 - phi**2), 0.0, 1e-4


def test_the_split_tail_reads_the_threshold_a_twenty_times_longer_count_reads():
    """White innovations, k 0.5: 40 h leave the share 1 alarm (split), 800 h count it at 20 (measured)."""
    for args in (_white(), _white(1)):
        share = 10.0 / 40.0
        long = counted_tail(args, 0.5, share, 800.0, 60, 11)
        short = counted_tail(args, 0.5, share, 40.0, 60, 12)
        assert long.how == "measured" and short.how != "measured"
        assert np.count_nonzero(long.maxima > short.h) == pytest.approx(20, abs=10)


def test_a_slow_wander_s_tail_beyond_the_counts_is_heavier_than_their_exponential_tail_and_the_split_carries_it():
    args = _white(1)
    share = 10.0 / 40.0
    long = counted_tail(args, 0.5, share, 800.0, 60, 13)
    short = counted_tail(args, 0.5, share, 40.0, 60, 14)
    exp_h, _ = threshold_for(short.maxima, 40.0, share)
    assert short.how == "split" and short.h > exp_h
    assert np.count_nonzero(long.maxima > exp_h) > np.count_nonzero(long.maxima > short.h)
