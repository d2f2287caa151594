"""The vibration line's frequency interval: coverage over many noisy sinusoids made here from first principles
(point samples of sin, not the simulator's interval means), fixed seeds, binomial bounds."""
import numpy as np
from scipy import stats

from nav_core.sensor_model import SensorModel, TriadModel

from imu_sim.diagnose import noise_tests
from imu_sim.diagnose.spectral import Whitener

RATE_HZ, N = 50.0, 2000
GYRO_WHITE, ACCEL_WHITE = 2e-4, 1e-3
"""Model white noise, rad/s/sqrt(s) and m/s/sqrt(s)."""
TRIALS = 200


def _line_case(rng):
    """Six channels of white noise, a line at a random frequency and phase on gyro x and accel z; (resid, f, sd)."""
    dt = 1.0 / RATE_HZ
    t = dt * np.arange(1, N + 1) + rng.uniform(0, 100)  # any start time: the frequency must not care
    f = rng.uniform(3.0, 22.0)
    sigma = np.repeat([GYRO_WHITE, ACCEL_WHITE], 3) / np.sqrt(dt)
    amp = np.zeros(6)
    amp[0], amp[5] = sigma[0] * rng.uniform(0.15, 0.4), sigma[5] * rng.uniform(0.15, 0.4)
    resid = rng.normal(0.0, 1.0, (N, 6)) * sigma + np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi))[:, None] * amp
    # Cramer-Rao sd of a real sinusoid's frequency, amplitudes A_c in noise sigma_c per sample: var(w) = 24/(n^3 sum
    # A^2/sigma^2) (rad/sample)^2; independent of the code under test
    sd = np.sqrt(24.0 / (N**3 * np.sum(amp**2 / sigma**2))) / (2 * np.pi * dt)
    return resid, f, sd


def _fit(resid):
    model = SensorModel(gyro=TriadModel(white_noise=np.full(3, GYRO_WHITE)),
                        accel=TriadModel(white_noise=np.full(3, ACCEL_WHITE)), sample_rate_hz=RATE_HZ)
    wh = Whitener.from_model(model, resid, 1.0 / RATE_HZ)
    lr, _, f0, n_bins = noise_tests.vibration_scan(wh, np.fft.rfft(resid, axis=0), 1.0)
    # the diagnosis fits a line only when it is significant (Bonferroni over the bins searched)
    return noise_tests.fit_line_frequency(wh, resid, f0) if lr > 2 * np.log(n_bins / 0.05) else None


def test_line_frequency_interval_covers_at_its_level_and_has_the_cramer_rao_width():
    rng = np.random.default_rng(20261125)
    covered, width_ratio, z = 0, [], []
    for _ in range(TRIALS):
        resid, f, sd = _line_case(rng)
        fitted = _fit(resid)
        if fitted is None:
            continue
        f_hat, lo, hi = fitted
        covered += lo <= f <= hi
        width_ratio.append((hi - lo) / (2 * 1.959964 * sd))
        z.append((f_hat - f) / sd)
    n_found = len(z)
    assert n_found > 0.9 * TRIALS, n_found
    # 95 % intervals: coverage inside the binomial 0.1 %..99.9 % range (175..193 of the 195 lines found)
    lo_n, hi_n = stats.binom.ppf(0.001, n_found, 0.95), stats.binom.isf(0.001, n_found, 0.95)
    assert lo_n <= covered <= hi_n, (covered, lo_n, hi_n)
    # the width is the Cramer-Rao one from all channels (the old peak-channel rule: median 0.76 of it, 150 of
    # 195 covered on these trials)
    assert 0.85 < np.median(width_ratio) < 1.15, np.median(width_ratio)
    # the estimate is unbiased and efficient: mean z within 4 standard errors of 0, spread ~1
    assert abs(np.mean(z)) < 4 / np.sqrt(n_found) and 0.8 < np.std(z) < 1.25, (np.mean(z), np.std(z))
