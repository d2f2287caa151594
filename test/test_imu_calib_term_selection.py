"""imu_calib.noise_fit term selection (issue 14): a term the data show is kept, a term the record cannot identify
gets an upper bound (never 0), a misfit beyond the Allan variance's dof is said, the Kalibr export is positive."""
import subprocess

import numpy as np
import pytest
import yaml
from scipy import stats

from imu_calib import model_io, synthetic
from imu_calib.allan import overlapping_adev
from imu_calib.allan_cov import allan_correlation
from imu_calib.characterise import characterise, warnings_of, write_outputs
from imu_calib.noise_fit import NOT_IDENTIFIABLE, TERMS, _add_what_the_residual_asks_for, _Problem, fit_noise
from imu_calib.whittle import cramer_rao_relative_sd
from nav_core import sensor_model
from nav_core.processes import executable
from nav_core.recording import write_imu_csv

TWO_HOURS_S = 7200.0
RATE_HZ = 10.0
"""The random walk's information is the Fourier bins below K / (2 pi N) (about 1 mHz here) whatever the
sample rate, so 10 Hz tests the same case as the reported 100 Hz record at a tenth of the cost."""
REPORTED_N = (2.9e-4, 3.5e-4, 4.1e-4)
REPORTED_K = (1.5e-6, 2.2e-6, 3.0e-6)
"""The reported failure: 2 h, gyro white noise and rate random walk per axis; the Allan deviation at 800 s is
2.6-3.5 times the white-noise line (measured 3.8) and the old fit returned K = 0 on all three axes."""


def _fit(n_coef, k_coef, seed, b_coef=0.0, rate=RATE_HZ, seconds=TWO_HOURS_S, whittle=True):
    x = synthetic.noise(int(seconds * rate), rate, synthetic.NoiseTerms(N=n_coef, B=b_coef, K=k_coef),
                        np.random.default_rng(seed))
    return fit_noise(overlapping_adev(x, rate), samples=x if whittle else None)


def _rise_at(tau, n_coef, k_coef):
    return np.sqrt(1.0 + k_coef ** 2 * tau ** 2 / (3.0 * n_coef ** 2))


@pytest.mark.slow
def test_reported_case_keeps_the_random_walk_as_precisely_as_the_cramer_rao_bound_allows_and_never_reports_zero():
    fits, truths = [], []
    for seed in range(20):
        rng = np.random.default_rng(seed)  # the three axes of one record are independent draws
        for n_coef, k_coef in zip(REPORTED_N, REPORTED_K):
            assert _rise_at(800.0, n_coef, k_coef) > 2.0  # the condition
            x = synthetic.noise(int(TWO_HOURS_S * RATE_HZ), RATE_HZ, synthetic.NoiseTerms(N=n_coef, K=k_coef), rng)
            fits.append(fit_noise(overlapping_adev(x, RATE_HZ), samples=x))
            truths.append(k_coef)
    truths = np.array(truths)
    kept = np.array([f.identifiable("K") for f in fits])
    reported = np.array([f.reported_value("K") for f in fits])
    assert np.all(reported > 0)
    # the old fit kept K on 0 of these axes; measured 54/60 (the rest pick flicker for the rise: few bins)
    assert kept.mean() >= 0.8, kept.mean()
    ratio = reported[kept] / truths[kept]
    # Cramer-Rao: K's relative sd is 20-24 % here (exact likelihood); an efficient unbiased estimator has
    # |error| < 25 % on ~75 % of axes: the pipeline must reach that within a 3-sigma binomial bound, counting
    # an axis where K was not identified as a miss, and its median must not be biased beyond 3 sigma
    bounds = np.array([cramer_rao_relative_sd(int(TWO_HOURS_S * RATE_HZ), RATE_HZ, "NK", (n, k))[1]
                       for n, k in zip(REPORTED_N, REPORTED_K)])
    p = float(np.mean(2 * stats.norm.cdf(0.25 / bounds) - 1))
    within = np.mean(kept & (np.abs(reported / truths - 1) < 0.25))
    assert within >= p - 3 * np.sqrt(p * (1 - p) / len(fits)), (within, p)
    assert abs(np.median(ratio) - 1) < 3 * 1.25 * bounds.max() / np.sqrt(len(ratio)), np.median(ratio)
    covered = [f.intervals["K"][0] <= k <= f.intervals["K"][1] for f, k in zip(fits, truths)]
    assert np.mean(covered) >= 0.85, np.mean(covered)  # 95 % intervals (estimates) or [0, bound]


@pytest.mark.slow
def test_random_walk_within_25_percent_on_every_axis_where_the_record_carries_the_information():
    # K 10x the reported one: the random walk owns ~70 bins of 2 h, Cramer-Rao sd 7-8 %
    ks = (1.5e-5, 2.0e-5, 2.5e-5)
    errors = np.array([[_fit(n, k, seed).values["K"] / k - 1 for n, k in zip(REPORTED_N, ks)]
                       for seed in range(20)])
    assert np.all(np.abs(errors) < 0.25), np.abs(errors).max()
    assert np.median(np.abs(errors)) < 0.10


@pytest.mark.slow
def test_bias_instability_at_its_flat_region_is_kept_within_25_percent():
    # B's flat level (0.664 B = 6.6e-5) stands 2.2x above the white + random-walk minimum (3.0e-5)
    n_coef, b_coef, k_coef = 3.5e-4, 1e-4, 2.2e-6
    fits = [_fit(n_coef, k_coef, seed, b_coef=b_coef) for seed in range(20)]
    assert all(f.identifiable("B") for f in fits)
    errors = np.abs(np.array([f.values["B"] for f in fits]) / b_coef - 1)
    assert np.all(errors < 0.25) and np.median(errors) < 0.10, errors


def test_a_term_the_record_cannot_identify_gets_an_upper_bound_and_is_marked_never_zero():
    # 10 minutes cannot show a random walk of 2e-6 next to white noise of 3.5e-4 (rise 1.0003x at 300 s)
    fit = _fit(3.5e-4, 2.2e-6, 3, seconds=600.0)
    assert not fit.identifiable("K") and fit.values["K"] == 0.0
    assert fit.upper_bounds["K"] > 0 and fit.reported_value("K") == fit.upper_bounds["K"]
    # the interval also covers the term sets the data cannot tell from the chosen one; the value the filter is
    # tuned with stays the chosen set's bound
    assert fit.intervals["K"][0] == 0.0 and fit.intervals["K"][1] >= fit.upper_bounds["K"]
    assert fit.summary()["terms"]["K"] == NOT_IDENTIFIABLE


def test_an_unidentified_terms_value_is_the_chosen_sets_bound_not_the_wider_covering_one():
    # the covering bound (every term set the data do not reject) on a short record is far above the chosen
    # set's: as the model's value it tuned the Katwijk rover's filter 25x worse (0.12 -> 3.1 m RMS)
    fit = _fit(3.5e-4, 2.2e-6, 3, seconds=600.0)
    assert fit.intervals["K"][1] > fit.upper_bounds["K"] == fit.reported_value("K")


def test_sensor_model_and_kalibr_carry_upper_bounds_with_their_marks(tmp_path):
    truth = sensor_model.SensorModel(gyro=sensor_model.TriadModel(white_noise=np.full(3, 3.5e-4),
                                                                  rate_random_walk=np.full(3, 2.2e-6)),
                                     accel=sensor_model.TriadModel(white_noise=np.full(3, 1e-3)), sample_rate_hz=10.0)
    result = characterise(synthetic.static_recording(truth, 600.0, np.random.default_rng(4)))
    paths = write_outputs(result, tmp_path)
    model = sensor_model.load(paths["sensor_model"])
    k = model.gyro.rate_random_walk
    assert np.all(k > 0) and not np.any(model.gyro.identifiable["rate_random_walk"])
    assert np.all(k <= model.gyro.intervals["rate_random_walk"][:, 1])  # the chosen set's bound within the covering one
    assert set(model.gyro.info["fit_quality"].values()) <= {"good", "poor"}
    text = paths["kalibr"].read_text()
    kalibr = yaml.safe_load(text)
    for key in ("gyroscope_noise_density", "gyroscope_random_walk", "accelerometer_noise_density",
                "accelerometer_random_walk"):
        assert kalibr[key] > 0, key
    assert kalibr["gyroscope_random_walk"] == pytest.approx(k.max())
    assert "upper bound" in text and NOT_IDENTIFIABLE in text
    assert any("gyroscope_random_walk" in w and "upper bound" in w for w in warnings_of(result))


def test_kalibr_export_refuses_a_zero_instead_of_writing_it(tmp_path):
    model = sensor_model.SensorModel(gyro=sensor_model.TriadModel(white_noise=np.full(3, 1e-3)),
                                     accel=sensor_model.TriadModel(white_noise=np.full(3, 1e-3)))
    with pytest.raises(model_io.KalibrError, match="gyroscope_random_walk"):
        model_io.save_kalibr(model, tmp_path / "imu.yaml")
    assert not (tmp_path / "imu.yaml").exists()


def test_a_misfit_beyond_the_dof_brings_back_the_term_the_residual_asks_for():
    x = synthetic.noise(72_000, RATE_HZ, synthetic.NoiseTerms(N=3.5e-4, K=2e-5), np.random.default_rng(5))
    prob = _Problem(overlapping_adev(x, RATE_HZ))
    prob.set_correlation(list(TERMS), 0.0)
    assert prob.fit(["N"], 0.0, 0.0).p_value() < 1e-6
    kept = _add_what_the_residual_asks_for(prob, list(TERMS), ["N"], {"K": 1.0}, 0.0, 0.0)
    assert "K" in kept


@pytest.mark.slow
def test_a_curve_the_five_terms_cannot_explain_is_called_poor_in_the_yaml_and_on_the_terminal(tmp_path):
    truth = sensor_model.SensorModel(gyro=sensor_model.TriadModel(white_noise=np.full(3, 3e-4)),
                                     accel=sensor_model.TriadModel(white_noise=np.full(3, 1e-3)), sample_rate_hz=10.0)
    rec = synthetic.static_recording(truth, 1800.0, np.random.default_rng(6))
    rec.gyro[:, 0] += 2e-4 * np.sin(2 * np.pi * rec.t / 40.0)  # a 40 s oscillation: a bump no term has
    csv = write_imu_csv(tmp_path / "bump.csv", rec)
    proc = subprocess.run([executable("imu-calib"), "allan", str(csv), "--out", str(tmp_path / "out"),
                           "--no-progress"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "warning: gyro x: poor" in proc.stderr
    model = sensor_model.load(tmp_path / "out" / "sensor_model.yaml")
    assert model.gyro.info["fit_quality"]["x"] == "poor"
    assert model.gyro.info["noise_fit"]["x"]["fit_quality"]["p_value"] < 1e-3


@pytest.mark.parametrize("terms, coefficients", [({"N": 1e-6}, synthetic.NoiseTerms(N=1e-3)),
                                                 ({"N": 1e-6, "K": 1e-8}, synthetic.NoiseTerms(N=1e-3, K=1e-4))],
                         ids=["white", "white+walk"])
def test_allan_point_correlation_matches_monte_carlo(terms, coefficients):
    rate, n = 10.0, 8192
    runs = np.array([overlapping_adev(synthetic.noise(n, rate, coefficients, np.random.default_rng(s)), rate).avar
                     for s in range(300)])
    taus = overlapping_adev(np.zeros(n), rate).taus
    predicted = allan_correlation(taus, n, rate, terms)
    measured = np.corrcoef(runs.T)
    # neighbours and next neighbours away from the last two points (few clusters: the long-record law bends)
    for lag in (1, 2):
        i = np.arange(len(taus) - lag - 2)
        # sd of a correlation estimate from 300 runs is (1 - rho^2) / sqrt(300) < 0.058
        np.testing.assert_allclose(measured[i, i + lag], predicted[i, i + lag], atol=0.15)


@pytest.mark.slow
@pytest.mark.parametrize("whittle", [True, False], ids=["pipeline", "allan_fit_alone"])
def test_random_walk_95_percent_interval_covers_the_truth_on_95_percent_of_axes(whittle):
    # issue 14's case at 1 Hz (the same information on K as 100 Hz, a hundredth of the cost), 100 seeds x 3 axes:
    # coverage within 3 binomial sigma of 95 % (was 274/300 with the likelihood, 269/300 with the Allan fit alone:
    # a dropped K's bound came from the fit where flicker had taken the rise, and a low K's symmetric interval
    # ended below the truth). Measured 281/300 and 288/300; the exact ML with the true terms covers 285/300.
    rate, n = 1.0, int(TWO_HOURS_S)
    covered = []
    for seed in range(100):
        rng = np.random.default_rng(seed)
        for n_coef, k_coef in zip(REPORTED_N, REPORTED_K):
            x = synthetic.noise(n, rate, synthetic.NoiseTerms(N=n_coef, K=k_coef), rng)
            lo, hi = fit_noise(overlapping_adev(x, rate), samples=x if whittle else None).intervals["K"]
            covered.append(lo <= k_coef <= hi)
    share = float(np.mean(covered))
    assert share >= 0.95 - 3 * np.sqrt(0.95 * 0.05 / len(covered)), share
    assert share <= 0.995, share  # not bought with intervals that say nothing
