"""A hand-mounted rate table's scale factor fitted with each gyro's slow bias drift (warm-up, remount steps)."""
import numpy as np
from scipy.spatial.transform import Rotation
from table_case import scale_errors_in_half_widths, scale_factor_case

DT, PER = 0.02, 3000
SCALE = np.array([2e-2, -1.5e-2, 2.5e-2])
RATES_DPS = (30.0, -30.0, 100.0, -100.0, 200.0, -200.0)
WARMUP = (5e-3, 80.0)


def _table(seed: int, drift: bool):
    """A consumer unit on a level table in three mountings (body z, x, y up; 60 s each), a 10-s rest, then
    dwelling at RATES_DPS for 4-7 s each; gyro residual = the scale factors SCALE times the rate, white noise
    (3e-4 rad/s/sqrt(s)) and, with ``drift``, a warm-up (WARMUP: rad/s, s) and a bias step at each remount (a
    g-sensitivity: 2e-3 rad/s sd). Returns (ctx, scale-factor candidate)."""
    rng = np.random.default_rng(seed)
    n = 3 * PER
    t = DT * np.arange(1, n + 1)
    rates = []
    for _ in range(3):  # each mounting: a rest, the dwells, a rest
        run = [0.0] * int(10.0 / DT)
        for r in RATES_DPS:
            run += [np.radians(r)] * int(rng.uniform(4.0, 7.0) / DT)
        rates += (run + [0.0] * PER)[:PER]
    w = np.array(rates)
    psi = np.cumsum(w) * DT
    nominal = Rotation.from_euler("z", psi[:, None]).as_matrix() @ np.repeat(
        Rotation.from_euler("xyz", [[0, 0, 0], [0, -90, 0], [90, 0, 0]], degrees=True).as_matrix(), PER, axis=0)
    up = np.array([0.0, 0.0, 1.0])
    gyro = np.einsum("nji,j->ni", nominal, up) * w[:, None]
    accel = np.einsum("nji,j->ni", nominal, 9.81 * up)
    spec = [{"t0": 60.0 * j, "t1": 60.0 * (j + 1), "roll_deg": r, "pitch_deg": p, "rate_dps": 100.0}
            for j, (r, p) in enumerate([(0.0, 0.0), (0.0, -90.0), (90.0, 0.0)])]
    sd = np.array([3e-4, 3e-4, 3e-4, 1e-3, 1e-3, 1e-3]) / np.sqrt(DT)
    resid = rng.standard_normal((n, 6)) * sd
    resid[:, :3] += gyro * SCALE
    if drift:
        resid[:, :3] += WARMUP[0] * np.exp(-t / WARMUP[1])[:, None] * rng.uniform(0.3, 1.0, 3)
        resid[:, :3] += np.repeat(rng.normal(0.0, 2e-3, (3, 3)), PER, axis=0)
    return scale_factor_case(t, DT, gyro, accel, nominal, spec, resid, sd, 0.01)


def _z(seed: int, drift: bool) -> np.ndarray:
    """The fitted gyro scale factors' errors in half-widths of their 95 % intervals."""
    return scale_errors_in_half_widths(*_table(seed, drift), SCALE)


def test_a_tables_scale_factor_intervals_cover_it_under_the_units_slow_bias_drift():
    # fitted without the drift (white weights, one turn-on bias), 8 of these 12 intervals covered, misses of 1.3-1.7
    # half-widths
    z = np.array([_z(seed, True) for seed in range(4)])
    assert np.mean(np.abs(z) <= 1.0) >= 0.9 and np.abs(z).max() < 1.5, z
    # without drift the estimate is unbiased and the interval no wider than it needs (z spread about 1/1.96)
    z0 = np.array([_z(seed, False) for seed in range(4)])
    assert np.abs(z0).max() < 1.5 and 0.15 < np.std(z0) < 0.9, z0
