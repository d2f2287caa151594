"""Imperfect inputs (issue 24): a misstated noise model and a flicker bias instability are no finding; a moving
truth file's slow error is weighted as the reference's, not removed with the low-frequency physics."""
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

from nav_core.sensor_model import SensorModel, TriadModel

from imu_sim.diagnose import noise_tests, reference, robust_noise
from imu_sim.diagnose.spectral import Whitener, gls, noise_psd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import independent_gen as gen  # noqa: E402

DT, N = 0.2, 8192
WHITE, FLICKER = 2e-4, 2e-5
"""rad/s/sqrt(s) and rad/s: the corner of white and flicker near 1.6 mHz, as in the realistic benchmark."""


def _model(white_err=1.0, flicker_err=1.0):
    def tri():
        return TriadModel(white_noise=np.full(3, WHITE * white_err), bias_instability=np.full(3, FLICKER * flicker_err))
    return SensorModel(gyro=tri(), accel=tri(), sample_rate_hz=1 / DT)


def _walk_lr(x, model, extra="rw"):
    """Robust likelihood ratio of a bias random walk (or a 20-s Gauss-Markov bias) on channel 0 of x."""
    freqs, pgram = noise_tests.periodogram(noise_tests.detrended(x[:, None]), DT)
    shape = noise_tests.rw_extra(freqs) if extra == "rw" else noise_tests.gm_extra(freqs, 20.0)
    return robust_noise.extra_lr(pgram[:, 0], freqs, model, 0, [shape])[0]


def test_flicker_generator_has_the_stated_psd():
    rng = np.random.default_rng(3)
    x = gen.flicker(rng, 4096, DT, [FLICKER] * 200)
    freqs, pgram = noise_tests.periodogram(x, DT)
    band = (freqs > 0.01) & (freqs < 0.2)
    ratio = np.mean(pgram[band], axis=1) / (FLICKER**2 / (2 * np.pi * freqs[band]))
    assert abs(np.median(ratio) - 1.0) < 0.15


@pytest.mark.parametrize("white_err, flicker_err", [(0.9, 1.1), (1.1, 0.9), (0.92, 0.9), (1.08, 1.1)])
def test_misstated_noise_and_flicker_bias_instability_give_no_walk_or_gauss_markov(white_err, flicker_err):
    rng = np.random.default_rng(int(100 * white_err + 10 * flicker_err))
    model = _model(white_err, flicker_err)
    lrs = []
    for _ in range(6):
        x = rng.normal(0, WHITE / np.sqrt(DT), N) + gen.flicker(rng, N, DT, [FLICKER])[:, 0]
        lrs.append((_walk_lr(x, model), _walk_lr(x, model, "gm")))
    lrs = np.array(lrs)
    # per channel and term, against the 1 % point of chi-square(1) / (2) (the engine's per-channel cut)
    assert np.mean(lrs[:, 0] > stats.chi2.isf(0.01, 2)) <= 1 / 6
    assert np.mean(lrs[:, 1] > stats.chi2.isf(0.01, 3)) <= 1 / 6


def test_a_walk_well_above_the_flicker_is_still_found():
    rng = np.random.default_rng(8)
    x = (rng.normal(0, WHITE / np.sqrt(DT), N) + gen.flicker(rng, N, DT, [FLICKER])[:, 0]
         + np.cumsum(rng.normal(0, 1e-5 * np.sqrt(DT), N)))
    assert _walk_lr(x, _model(1.05, 0.95)) > stats.chi2.isf(1e-4, 2)


def test_a_model_stating_no_bias_instability_gets_no_flicker_allowance():
    comps, bounds = robust_noise.components(SensorModel(gyro=TriadModel(white_noise=np.full(3, WHITE))),
                                            0, np.linspace(0.01, 1, 10))
    assert len(comps) == 1 and bounds == [None]


def _moving_case(n, dt):
    return SimpleNamespace(scenario=SimpleNamespace(source="trajectory"), cache={"moving_file_truth": True}, dt=dt,
                           n=n)


def test_reference_error_is_weighted_so_a_slow_regressor_beyond_it_is_found_and_none_is_invented():
    n, dt = 60000, 0.02
    t = np.arange(n) * dt
    model = SensorModel(gyro=TriadModel(white_noise=np.full(3, WHITE)),
                        accel=TriadModel(white_noise=np.full(3, 1e-3)), sample_rate_hz=1 / dt)
    # a Coriolis-like regressor: a line at a figure-eight drive's 240-s period, 1 mm/s^2
    x = 1e-3 * np.sin(2 * np.pi * t / 240.0)[:, None]
    for seed in range(3):
        rng = np.random.default_rng(seed)
        # the reference's slow error: 5-30 cm of position wander at periods of 30-600 s, differentiated twice
        wander = gen.slow_wander(rng, t, (0.05, 0.3), (30.0, 600.0))[2]
        lrs = {}
        for amp in (0.0, 1.0):
            resid = rng.normal(0, 1e-3 / np.sqrt(dt), (n, 6))
            resid[:, 3:] += wander + amp * x
            psd = reference.with_reference_error(_moving_case(n, dt), resid,
                                                 noise_psd(model, np.fft.rfftfreq(n, dt), dt))
            wh = Whitener.from_psd(psd, resid, dt)
            lrs[amp] = gls(wh, np.fft.rfft(resid, axis=0), {3: x, 4: x}, 1).lr
        assert lrs[0.0] < stats.chi2.isf(0.01, 1)
        assert lrs[1.0] > stats.chi2.isf(1e-6, 1)


def test_an_out_of_bound_parameter_is_dropped_and_the_rest_refitted():
    from imu_sim.diagnose.candidate import Candidate
    from imu_sim.diagnose.engine import _refit_without

    def cand(params, stat=100.0):
        c = Candidate("scale_factor", stat, 10.0, "GLS", params=dict(params),
                      intervals={k: [v - 1e-4, v + 1e-4] for k, v in params.items()})
        c.refit = lambda names: cand({k: v for k, v in params.items() if k not in names}, stat / 2)
        return c
    both = cand({"gyro[x]": 0.5, "gyro[z]": 7e-4})
    broken = [{"parameter": "gyro[x]", "value": 0.5, "bound": 3e-2, "grade": "industrial"}]
    again = _refit_without(both, broken, "industrial")
    assert list(again.params) == ["gyro[z]"] and "Refitted without gyro[x]" in again.caveat
    assert _refit_without(cand({"gyro[x]": 0.5}), broken, "industrial") is None  # nothing left to refit
    weak = cand({"gyro[x]": 0.5, "gyro[z]": 7e-4}, stat=15.0)  # the rest no longer significant
    assert _refit_without(weak, broken, "industrial") is None
