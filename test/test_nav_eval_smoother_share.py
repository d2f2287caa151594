"""The ideal case behind issue 25's "smoothed error no larger than the forward one in >= 95 % of epochs": on a
linear-Gaussian INS-like system whose filter model is the truth's, the exact RTS smoother's error is orthogonal to
its correction, and the share of epochs it wins is what the theory gives from the two covariances - about 86 % with
1-Hz fixes throughout, well short of 95 %; inside a 60-s outage it wins more often (about 92 %)."""
import numpy as np

from nav_eval.smoother_share import epoch_kinds, linear_monte_carlo, share_1d


def test_an_optimal_smoother_wins_the_share_the_theory_gives_and_not_95_percent_with_gnss_throughout():
    n = 480  # 4 minutes at 2 Hz, a fix every second
    fixes = np.arange(n) % 2 == 0
    r = linear_monte_carlo(fixes, runs=60, seed=3)
    steady = slice(120, n - 120)
    measured, theory = r["no_worse"][:, steady].mean(), r["theory"][steady].mean()
    assert abs(r["corr"]) < 0.03  # e_s orthogonal to d = e_f - e_s
    assert abs(measured - theory) < 0.03, (measured, theory)  # measured 0.856 against 0.858
    assert 0.80 < theory < 0.90
    assert abs(share_1d(12.6, 1.0) - 0.95) < 0.001  # one axis: 95 % needs a forward std 12.6x the smoothed one


def test_inside_an_outage_the_optimal_smoother_wins_far_more_often():
    t = np.arange(480) * 0.5
    kind = epoch_kinds(t, [(100.0, 160.0)], 30.0)
    assert np.count_nonzero(kind == 0) == 121 and np.count_nonzero(kind == 1) == 60
    r = linear_monte_carlo((np.arange(480) % 2 == 0) & (kind != 0), runs=60, seed=4)
    inside, with_gnss = r["no_worse"][:, kind == 0].mean(), r["no_worse"][:, kind == 2].mean()
    assert inside > with_gnss + 0.03, (inside, with_gnss)  # measured 0.904 against 0.856
