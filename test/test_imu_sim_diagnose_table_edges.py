"""A rate table's cut dwell edges carry nothing into the slow noise tests (Gauss-Markov bias, random walk)."""
from types import SimpleNamespace

import numpy as np
import pytest

from nav_core.sensor_model import SensorModel, TriadModel

from imu_sim.diagnose import reference
from imu_sim.diagnose.candidate import Context
from imu_sim.diagnose.noise_candidates import noise
from imu_sim.diagnose.unstated import fill_unstated

DT = 0.01
GYRO_WHITE, ACCEL_WHITE = 2e-5, 1e-4
"""A tactical unit's white noise (rad/s/sqrt(s), m/s/sqrt(s))."""
RATES_DPS = (30.0, -30.0, 60.0, -60.0, 110.0, -110.0)
TILT_RAD = np.radians(0.8)
"""A hand mounting's tilt: the table rate shows on a cross axis as rate x tilt (a constant over each dwell)."""


def _table(seed: int, gm_sigma: float = 0.0, gm_tau: float = 0.5):
    """A 100-Hz table: a 10-s rest, dwells of 3-8 s at RATES_DPS twice, each dwell's first 0.3-0.6 s cut as an
    unsettled edge and filled as :func:`unstated.fill_unstated` fills it; the gyro y residual carries the rate x
    TILT_RAD of each dwell, white noise and, with ``gm_sigma`` (rad/s), a Gauss-Markov bias on gyro y. Returns
    the Context of the Gauss-Markov test."""
    rng = np.random.default_rng(seed)
    spans_s, t0 = [(0.0, 10.0, 0.0)], 10.0
    for r in RATES_DPS * 2:
        d = rng.uniform(3.0, 8.0)
        spans_s.append((t0 + 0.5, t0 + 0.5 + d, r))  # 0.5-s ramps between the dwells, unstated
        t0 += 0.5 + d
    n = int(t0 / DT)
    t = DT * np.arange(1, n + 1)
    rate, unstated = np.zeros(n), np.ones(n, bool)
    for a, b, r in spans_s:
        m = (t > a) & (t <= b)
        rate[m] = np.radians(r)
        idx = np.flatnonzero(m)
        unstated[idx[int(rng.uniform(0.3, 0.6) / DT) if r else 0:]] = False
    sd = np.array([GYRO_WHITE] * 3 + [ACCEL_WHITE] * 3) / np.sqrt(DT)
    resid = rng.standard_normal((n, 6)) * sd
    resid[:, 1] += rate * TILT_RAD
    if gm_sigma:
        phi = np.exp(-DT / gm_tau)
        x = np.zeros(n)
        e = rng.standard_normal(n) * gm_sigma * np.sqrt(1 - phi**2)
        for k in range(1, n):
            x[k] = phi * x[k - 1] + e[k]
        resid[:, 1] += x
    resid = fill_unstated(resid, unstated)
    spec = [{"t0": a, "t1": b, "roll_deg": 0.0, "pitch_deg": 0.0, "yaw_deg": 0.0, "rate_dps": r}
            for a, b, r in spans_s]
    gyro_true = np.zeros((n, 3))
    gyro_true[:, 2] = np.where(unstated, 0.0, rate)
    case = SimpleNamespace(t=t, sim_t_abs=t, n=n, dt=DT, gyro_true=gyro_true, cache={}, unstated=unstated,
                           scenario=SimpleNamespace(source="static_segments", spec=spec))
    model = SensorModel(gyro=TriadModel(white_noise=np.full(3, GYRO_WHITE)),
                        accel=TriadModel(white_noise=np.full(3, ACCEL_WHITE)), sample_rate_hz=1.0 / DT)
    return Context(case, model, resid, m_tests=14)


def test_hold_demeaned_leaves_a_tables_cut_edges_at_zero_and_demeans_the_stated_samples():
    ctx = _table(1)
    out = reference.hold_demeaned(ctx.case, ctx.resid)
    assert np.all(out[ctx.case.unstated] == 0.0)
    for a, b in reference.holds(ctx.case):
        keep = ~ctx.case.unstated[a:b]
        assert np.allclose(out[a:b][keep].mean(axis=0), 0.0, atol=1e-12)


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_a_tables_dwell_edges_are_no_gauss_markov_bias(seed):
    # the fill of a cut edge passes from the dwell before to this one: 1e-3 rad/s apart on gyro y at 0.8 deg of
    # tilt; demeaned with it, each edge was a short ramp the test took for a wander at tau ~0.3 s
    cand = noise(_table(seed), "gauss_markov_bias")
    assert not cand.significant, (cand.stat, cand.threshold, cand.channels)


@pytest.mark.parametrize("seed", [1, 2])
def test_a_real_short_gauss_markov_bias_on_a_table_is_still_found(seed):
    cand = noise(_table(seed, gm_sigma=2e-4, gm_tau=0.5), "gauss_markov_bias")
    assert cand.significant and "gyro_y" in cand.channels, (cand.stat, cand.threshold, cand.channels)
