"""The 15-state INS error model: named indices, continuous dynamics F, noise input G, process noise from the sensor model.

States (estimate minus truth): ``DP`` position (ENU, m), ``DV`` velocity (ENU, m/s),
``PHI`` attitude error (ENU, rad; ``C_est = (I - [phi x]) C_true``), ``BG`` gyro
bias error (body, rad/s), ``BA`` accel bias error (body, m/s^2)::

    dp'  = dv
    dv'  = [f_n x] phi - C_nb ba - (2 w_ie + w_en) x dv + C_nb n_a
    phi' = -w_in x phi + C_nb bg - C_nb n_g
    b'   = -b / tau + n_b      (first-order Gauss-Markov; tau = inf: random walk)

Optional (``estimate_scale_factors``): 21 states, ``SG`` gyro and ``SA`` accel scale-factor errors
(body, unitless, random constants). With measured = (1 + s) true + b, corrected = measured (1 - s_est) - b_est::

    dv'  += -C_nb diag(f_b) sa        phi' += C_nb diag(w_b) sg
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from nav_core import sensor_model as sm
from nav_core.units import DEG, DEG_PER_H, MG

DP, DV, PHI, BG, BA = (slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12), slice(12, 15))
STATES = ["dpe", "dpn", "dpu", "dve", "dvn", "dvu", "phie", "phin", "phiu",
          "bgx", "bgy", "bgz", "bax", "bay", "baz"]
N_STATES = len(STATES)
SG, SA = slice(15, 18), slice(18, 21)
N_STATES_SF = 21  # with gyro and accel scale-factor errors
YAW = slice(PHI.stop - 1, PHI.stop)  # the heading error: the up component of PHI
"""Named blocks of the error state: every module outside this one indexes states only through these."""


def with_random_walks(f_cont, g_cont, drives):
    """``F``, ``G`` with one random-walk state appended per entry of ``drives`` (its driving density, state unit
    per sqrt(s)): the odometer scale, the mounting angles."""
    n, m = g_cont.shape
    k = len(drives)
    f = np.zeros((n + k, n + k))
    g = np.zeros((n + k, m + k))
    f[:n, :n] = f_cont
    g[:n, :m] = g_cont
    g[n:, m:] = np.diag(drives)
    return f, g


def index(*blocks: slice) -> np.ndarray:
    """Integer state indices of the named ``blocks`` (slices above), in the order given."""
    return np.concatenate([np.arange(b.start, b.stop) for b in blocks])
N_NOISES = 12  # gyro white, accel white, gyro bias driving, accel bias driving


@dataclass(frozen=True)
class NoiseModel:
    """Continuous noise densities per axis (SI) and bias correlation times (s; inf = random walk)."""

    gyro_white: np.ndarray       # rad/sqrt(s)
    accel_white: np.ndarray      # m/s/sqrt(s)
    gyro_bias_drive: np.ndarray  # rad/s/sqrt(s)
    accel_bias_drive: np.ndarray  # m/s^2/sqrt(s)
    gyro_bias_tau: np.ndarray    # s
    accel_bias_tau: np.ndarray   # s


def default_mems_model() -> sm.SensorModel:
    """Hand-tuned MEMS defaults (ADXRS300/ADXL210-class datasheet magnitudes) for when no Allan model exists."""
    model = sm.SensorModel(sample_rate_hz=64.0, provenance={"tool": "ins_gps_kf.error_model.default_mems_model",
                                                            "source": "hand-tuned datasheet magnitudes"})
    model.gyro.white_noise = np.full(3, 0.1 * DEG)                  # 0.1 deg/sqrt(s) = 6 deg/sqrt(h)
    model.gyro.bias_instability = np.full(3, 50.0 * DEG_PER_H)
    model.gyro.rate_random_walk = np.full(3, 1.0 * DEG_PER_H / 60.0)
    model.accel.white_noise = np.full(3, 2e-3)                       # m/s/sqrt(s)
    model.accel.bias_instability = np.full(3, 1.0 * MG)
    model.accel.rate_random_walk = np.full(3, 1e-5)
    return model


def _bias_drive(triad: sm.TriadModel, flicker_tau: float):
    """Bias-state driving density and correlation time per axis from B, tau_B and K."""
    tau = np.where(triad.bias_correlation_time > 0, triad.bias_correlation_time, flicker_tau)
    drive2 = 2.0 * triad.bias_instability**2 / tau + triad.rate_random_walk**2
    tau = np.where(triad.bias_instability > 0, tau, np.inf)  # no instability term: pure random walk
    return np.sqrt(drive2), tau


def noise_from_sensor_model(model: sm.SensorModel, flicker_tau_s: float = 300.0) -> NoiseModel:
    """Process-noise densities from the sensor model (flicker bias approximated as Gauss-Markov)."""
    g_drive, g_tau = _bias_drive(model.gyro, flicker_tau_s)
    a_drive, a_tau = _bias_drive(model.accel, flicker_tau_s)
    return NoiseModel(model.gyro.white_noise.copy(), model.accel.white_noise.copy(), g_drive, a_drive, g_tau, a_tau)


@njit(cache=True)
def _skew(v):
    """nav_core.frames.skew for one vector, compiled (called per epoch inside the kernel below)."""
    return np.array(((0.0, -v[2], v[1]), (v[2], 0.0, -v[0]), (-v[1], v[0], 0.0)))


@njit(cache=True)
def _dynamics(mat_nb, f_n, w_ie_n, w_en_n, gyro_white, accel_white, gyro_drive, accel_drive, gyro_rate,
              accel_rate):
    f = np.zeros((N_STATES, N_STATES))
    g = np.zeros((N_STATES, N_NOISES))
    for i in range(3):
        f[i, 3 + i] = 1.0
        f[9 + i, 9 + i] = -gyro_rate[i]
        f[12 + i, 12 + i] = -accel_rate[i]
        g[9 + i, 6 + i] = gyro_drive[i]
        g[12 + i, 9 + i] = accel_drive[i]
    f[3:6, 3:6] = -_skew(2.0 * w_ie_n + w_en_n)
    f[3:6, 6:9] = _skew(f_n)
    f[3:6, 12:15] = -mat_nb
    f[6:9, 6:9] = -_skew(w_ie_n + w_en_n)
    f[6:9, 9:12] = mat_nb
    for j in range(3):
        g[3:6, 3 + j] = mat_nb[:, j] * accel_white[j]
        g[6:9, j] = -mat_nb[:, j] * gyro_white[j]
    return f, g


def dynamics(mat_nb, f_n, w_ie_n, w_en_n, noise: NoiseModel):
    """Continuous ``F`` (15, 15) and noise input ``G`` (15, 12) at attitude ``mat_nb`` and ENU specific force (m/s^2)."""
    return _dynamics(np.ascontiguousarray(mat_nb, dtype=float), np.asarray(f_n, float), np.asarray(w_ie_n, float),
                     np.asarray(w_en_n, float), noise.gyro_white, noise.accel_white, noise.gyro_bias_drive,
                     noise.accel_bias_drive, 1.0 / noise.gyro_bias_tau, 1.0 / noise.accel_bias_tau)


def with_scale_factors(f_cont, g_cont, mat_nb, w_b, f_b):
    """``F`` (21, 21) and ``G`` (21, 12) from the 15-state ones, adding the scale-factor columns at body rate
    ``w_b`` (rad/s) and specific force ``f_b`` (m/s^2); the scale factors are random constants."""
    f = np.zeros((N_STATES_SF, N_STATES_SF))
    g = np.zeros((N_STATES_SF, g_cont.shape[1]))
    f[:N_STATES, :N_STATES] = f_cont
    g[:N_STATES] = g_cont
    f[DV, SA] = -mat_nb * np.asarray(f_b)[None, :]
    f[PHI, SG] = mat_nb * np.asarray(w_b)[None, :]
    return f, g


def initial_covariance(pos_std, vel_std, att_std, gyro_bias_std, accel_bias_std, *scale_stds):
    """Diagonal initial covariance from per-block stds (each scalar or (3,), SI units); two more blocks
    (gyro and accel scale-factor stds, unitless) give the 21-state covariance."""
    std = np.concatenate([np.broadcast_to(s, 3) for s in (pos_std, vel_std, att_std, gyro_bias_std,
                                                           accel_bias_std, *scale_stds)])
    return np.diag(std.astype(float) ** 2)
