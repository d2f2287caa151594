"""A hand-mounted rate table whose dwells are each off their stated rate: the scale factors' intervals carry it."""
import numpy as np
from scipy.spatial.transform import Rotation
from table_case import scale_errors_in_half_widths, scale_factor_case

DT, PER = 0.01, 6000
SCALE = np.array([4e-4, -3e-4, 5e-4])
"""A tactical unit's gyro scale factors."""
RATES_DPS = (30.0, -30.0, 60.0, -60.0, 110.0, -110.0)
GYRO_WHITE = 2e-5
"""rad/s/sqrt(s)."""


def _table(seed: int, rate_err: float):
    """A tactical unit on a level table in three mountings (body z, x, y up; 60 s each): a 10-s rest, dwells at
    RATES_DPS for 3-8 s each, a rest; each dwell typed as its own segment, its true rate off the stated one by up to
    ``rate_err`` (relative). Gyro residual = SCALE times the stated rate, plus the rate error, plus white noise.
    Returns (ctx, scale-factor candidate)."""
    rng = np.random.default_rng(seed)
    n = 3 * PER
    t = DT * np.arange(1, n + 1)
    w, err, spec = np.zeros(n), np.zeros(n), []
    mounts = [(0.0, 0.0), (0.0, -90.0), (90.0, 0.0)]
    for j, (roll, pitch) in enumerate(mounts):
        k = j * PER + int(10.0 / DT)
        spec.append({"t0": t[j * PER] - DT / 2, "t1": t[k - 1], "roll_deg": roll, "pitch_deg": pitch, "rate_dps": 0.0})
        for r in RATES_DPS:
            d = int(rng.uniform(3.0, 8.0) / DT)
            w[k:k + d], err[k:k + d] = np.radians(r), rng.uniform(-rate_err, rate_err)
            spec.append({"t0": t[k] - DT / 2, "t1": t[k + d - 1], "roll_deg": roll, "pitch_deg": pitch,
                         "rate_dps": r})
            k += d
        spec.append({"t0": t[k] - DT / 2, "t1": t[(j + 1) * PER - 1], "roll_deg": roll, "pitch_deg": pitch,
                     "rate_dps": 0.0})
    psi = np.cumsum(w) * DT
    nominal = Rotation.from_euler("z", psi[:, None]).as_matrix() @ np.repeat(
        Rotation.from_euler("xyz", [[r, p, 0] for r, p in mounts], degrees=True).as_matrix(), PER, axis=0)
    up = np.array([0.0, 0.0, 1.0])
    gyro = np.einsum("nji,j->ni", nominal, up) * w[:, None]
    accel = np.einsum("nji,j->ni", nominal, 9.81 * up)
    sd = np.array([GYRO_WHITE] * 3 + [1e-4] * 3) / np.sqrt(DT)
    resid = rng.standard_normal((n, 6)) * sd
    resid[:, :3] += gyro * (SCALE + err[:, None])
    return scale_factor_case(t, DT, gyro, accel, nominal, spec, resid, sd, 1.0, sim_t_abs=t)


def _z(seed: int, rate_err: float) -> np.ndarray:
    """The fitted gyro scale factors' errors in half-widths of their 95 % intervals."""
    return scale_errors_in_half_widths(*_table(seed, rate_err), SCALE)


def test_a_tables_scale_factor_intervals_carry_each_dwells_rate_error():
    # a 5e-5 table under a tactical unit: with white-noise intervals (+-6e-6) 6 of these 18 covered, misses up to 5.5
    # half-widths; widened by the dwells' scatter 14 of 18, the largest miss 1.35
    z = np.array([_z(seed, 5e-5) for seed in range(6)])
    assert np.mean(np.abs(z) <= 1.0) >= 0.7 and np.abs(z).max() < 1.6, z


def test_without_rate_errors_a_tables_scale_factor_intervals_are_not_widened():
    z = np.array([_z(seed, 0.0) for seed in range(6)])
    assert np.abs(z).max() < 1.5 and 0.2 < np.std(z) < 0.9, z
