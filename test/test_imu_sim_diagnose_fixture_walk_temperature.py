"""A fixture's slow level changes from hold to hold: a bias random walk and a logged temperature's curve both make
them; weighed on the gyros' hold means on one weighting, each is told from the other."""
from types import SimpleNamespace

import numpy as np

from nav_core.sensor_model import SensorModel, TriadModel

from imu_sim.diagnose import collinear, hold_noise

DT, HOLD_S, GAP_S, HOLDS = 0.1, 60.0, 8.0, 6
K = 1e-4
"""The own consumer fixture walk (rad/s/sqrt(s)), 1.5 times its floor."""
THRESHOLD = 19.7048
"""The temperature's and the walk's threshold (six parameters) in the diagnosis."""


def _case(rng):
    """Six still 60-s holds, 8-s moves, 10 Hz; the temperature warming 8 degC at 250 s with a little noise."""
    per = int(round((HOLD_S + GAP_S) / DT))
    n = HOLDS * per
    spans = [(k * per, k * per + int(round(HOLD_S / DT))) for k in range(HOLDS)]
    t = np.arange(n) * DT
    temp = 24.0 + 8.0 * (1.0 - np.exp(-t / rng.uniform(200.0, 350.0))) + rng.normal(0.0, 0.05, n)
    return SimpleNamespace(t=t, dt=DT, n=n, gyro_true=np.zeros((n, 3)), cache={"holds": spans}, temp_c=temp,
                           scenario=SimpleNamespace(attitude_tolerance_deg=1.0))


def _model():
    return SensorModel(gyro=TriadModel(white_noise=np.full(3, 3e-4), bias_instability=np.full(3, 1.5e-5)),
                       accel=TriadModel(white_noise=np.full(3, 1e-3)), sample_rate_hz=1.0 / DT)


def _residual(rng, case, walk: float, coeff: float):
    """(n, 6) white noise, a gyro walk K = ``walk`` and a gyro temperature coefficient ``coeff`` rad/s/degC."""
    out = rng.normal(0.0, 3e-4 / np.sqrt(DT), (case.n, 6))
    out[:, :3] += np.cumsum(rng.normal(0.0, walk * np.sqrt(DT), (case.n, 3)), axis=0)
    out[:, :3] += coeff * (case.temp_c - 25.0)[:, None]
    return out


def _thresholds(axes: int = 3) -> tuple:
    return collinear._on_axes(THRESHOLD, 6, axes), collinear._on_axes(THRESHOLD, 6, axes)


def test_a_walk_takes_the_temperature_curves_place_on_the_hold_means():
    thr_t, thr_w = _thresholds()
    for seed in range(5):
        rng = np.random.default_rng(seed)
        case = _case(rng)
        got = hold_noise.walk_and_temperature(case, _model(), _residual(rng, case, K, 0.0), np.full(3, K * K))
        assert got["walk|temperature"] >= thr_w, (seed, got)
        assert got["temperature|walk"] < thr_t, (seed, got)


def test_a_temperature_curve_stands_given_a_false_walk_on_the_hold_means():
    thr_t, _ = _thresholds()
    for seed in range(5):
        rng = np.random.default_rng(100 + seed)
        case = _case(rng)
        got = hold_noise.walk_and_temperature(case, _model(), _residual(rng, case, 0.0, 1.25e-4), np.full(3, K * K))
        assert got["temperature|walk"] >= thr_t, (seed, got)


def test_a_temperature_curve_is_not_ranked_where_the_found_walk_explains_the_holds():
    rng = np.random.default_rng(7)
    case = _case(rng)
    case.model = _model()
    resid = _residual(rng, case, K, 0.0)
    walk = SimpleNamespace(effect="bias_random_walk", significant=True, threshold=THRESHOLD,
                           params={f"gyro_rad_per_s_per_sqrt_s[{a}]": K for a in "xyz"})
    temp = SimpleNamespace(effect="temperature_bias", significant=True, identifiable=True, threshold=THRESHOLD,
                           reason="", given_rivals={})
    collinear.walk_or_temperature(case, {"bias_random_walk": walk, "temperature_bias": temp}, resid, case.model)
    assert temp.identifiable is False and "not significant on the holds" in temp.reason
    assert temp.given_rivals["bias_random_walk"] < THRESHOLD
