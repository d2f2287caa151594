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

Flicker bias instability as a sum of Gauss-Markov processes (``bias_gm_states_per_axis`` n > 1): the flicker
(one-sided PSD B^2/(pi f), Allan plateau 0.664 B) of each axis is ``b = c_1 + ... + c_n``, ``c_k' = -c_k/T_k + q_k w_k``
with T_k and q_k from :func:`flicker_gm_sum` (the sum's Allan deviation within 2.5 % of 0.664 B over 2 s to
``bias_gm_band_max_s``, 1000 s, for n = 3).
``BG``/``BA`` stay the *total* bias error (every measurement and the feedback see only the total); the states
``c_2 .. c_n`` of each axis follow the INS states (:func:`with_bias_components`), and with ``c_1 = b - sum c_k``::

    b'   = -b/T_1 + sum_k (1/T_1 - 1/T_k) c_k + q_1 w_1 + sum_k q_k w_k      c_k' = -c_k/T_k + q_k w_k

T_1 is the slowest, which also carries the rate random walk K (as the single state does). n = 1 is the single
Gauss-Markov state (sigma B, T = ``flicker_correlation_time_s``).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from numba import njit
from scipy.optimize import nnls

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
    # the further Gauss-Markov components of the flicker biases, one entry each: the bias axis it belongs to
    # (0-2 gyro x y z, 3-5 accel), its driving density (the axis's unit/sqrt(s)) and correlation time (s)
    extra_axis: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    extra_drive: np.ndarray = field(default_factory=lambda: np.zeros(0))
    extra_tau: np.ndarray = field(default_factory=lambda: np.ones(0))

    @property
    def n_extra(self) -> int:
        """Extra bias-component states: n - 1 per flicker axis with n Gauss-Markov states per axis, else 0."""
        return len(self.extra_axis)


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


ALLAN_PLATEAU = float(np.sqrt(2.0 * np.log(2.0) / np.pi))  # flicker's Allan deviation over B: 0.664
FLICKER_BAND_MIN_S = 2.0  # s, the shortest averaging time the Gauss-Markov sum fits (4 filter epochs at 2 Hz; below
# it a MEMS IMU's white noise dwarfs its flicker: the BP3010's accel crosses at 9 s, its gyro at 240 s)
GM_ALLAN_PEAK = 1.89  # a Gauss-Markov process's Allan deviation peaks at 1.89 T


def gm_allan_variance(tau, variance, corr_time):
    """Allan variance at averaging times ``tau`` (s) of a first-order Gauss-Markov process of stationary
    ``variance`` and correlation time ``corr_time`` (s): ``s^2/x^2 (2x - 3 + 4 e^-x - e^-2x)``, x = tau/T."""
    x = np.asarray(tau, float) / corr_time
    return variance / x**2 * (2.0 * x - 3.0 + 4.0 * np.exp(-x) - np.exp(-2.0 * x))


@lru_cache(maxsize=32)
def _unit_flicker_fit(n: int, tau_min_s: float, tau_max_s: float) -> tuple:
    """(T (n,) s ascending, variances (n,)) of n Gauss-Markov processes whose summed Allan variance best fits
    a unit flicker's (0.664^2) over averaging times tau_min_s..tau_max_s, in relative terms: T log-spaced from
    tau_min/1.89/p to tau_max/1.89*p (p, the overhang, searched), variances by non-negative least squares."""
    taus = np.geomspace(tau_min_s, tau_max_s, 60)
    best = None
    for pad in np.linspace(0.5, 3.0, 51):
        corr = np.geomspace(tau_min_s / GM_ALLAN_PEAK / pad, tau_max_s / GM_ALLAN_PEAK * pad, n)
        a = np.array([gm_allan_variance(taus, 1.0, t) for t in corr]).T / ALLAN_PLATEAU**2
        var, _ = nnls(a, np.ones(len(taus)))
        err = float(np.max(np.abs(np.sqrt(a @ var) - 1.0)))
        if best is None or err < best[0]:
            best = (err, corr, var)
    return best[1], best[2]


def flicker_gm_sum(bias_instability, n: int, tau_max_s: float, tau_min_s: float = FLICKER_BAND_MIN_S):
    """Correlation times T (n,) s and stationary sigmas (n,) (the unit of ``bias_instability`` B) of n Gauss-Markov
    processes whose sum has the flicker's Allan deviation 0.664 B over averaging times ``tau_min_s``..``tau_max_s``
    (over 2..1000 s within 2.5 % for n = 3, T 1.4, 24, 397 s; over 2..300 s within 1.2 % for n = 3, 8 % for n = 2).
    n = 1: the single process of before (sigma B, T ``tau_max_s``)."""
    if n == 1:
        return np.array([float(tau_max_s)]), np.array([float(bias_instability)])
    corr, var = _unit_flicker_fit(int(n), float(tau_min_s), float(tau_max_s))
    return corr.copy(), np.sqrt(var) * float(bias_instability)


def _bias_drive(triad: sm.TriadModel, flicker_tau: float, n: int = 1, band_max_s: float = 1000.0):
    """Bias-state driving densities and correlation times per axis from B, tau_B and K: the main state's (3,),
    (3,) (the slowest component, with K), and per axis the further components' drives and times (lists); only a
    flicker axis has further components (a Gauss-Markov or absent B has one state)."""
    extra_drive, extra_tau = [], []
    tau, sigma = np.empty(3), np.empty(3)
    for i in range(3):
        b, t_b = float(triad.bias_instability[i]), float(triad.bias_correlation_time[i])
        if t_b > 0 or b <= 0 or n == 1:
            tau[i], sigma[i] = (t_b if t_b > 0 else flicker_tau), b
            extra_drive.append([]), extra_tau.append([])
            continue
        corr, sig = flicker_gm_sum(b, n, band_max_s)
        tau[i], sigma[i] = corr[-1], sig[-1]
        extra_tau.append(list(corr[:-1])), extra_drive.append(list(np.sqrt(2.0 * sig[:-1] ** 2 / corr[:-1])))
    drive2 = 2.0 * sigma**2 / tau + triad.rate_random_walk**2
    tau = np.where(triad.bias_instability > 0, tau, np.inf)  # no instability term: pure random walk
    return np.sqrt(drive2), tau, extra_drive, extra_tau


def noise_from_sensor_model(model: sm.SensorModel, flicker_tau_s: float = 300.0, gm_per_axis: int = 1,
                            band_max_s: float = 1000.0) -> NoiseModel:
    """Process-noise densities from the sensor model; a flicker bias as one Gauss-Markov process of correlation
    time ``flicker_tau_s`` or, ``gm_per_axis`` > 1, a sum fitted to its Allan deviation from 2 s to ``band_max_s``."""
    g_drive, g_tau, g_xd, g_xt = _bias_drive(model.gyro, flicker_tau_s, gm_per_axis, band_max_s)
    a_drive, a_tau, a_xd, a_xt = _bias_drive(model.accel, flicker_tau_s, gm_per_axis, band_max_s)
    per_axis = list(zip(g_xd + a_xd, g_xt + a_xt))
    axis = np.array([i for i, (d, _) in enumerate(per_axis) for _ in d], dtype=int)
    drive = np.array([v for d, _ in per_axis for v in d], dtype=float)
    corr = np.array([v for _, t in per_axis for v in t], dtype=float)
    return NoiseModel(model.gyro.white_noise.copy(), model.accel.white_noise.copy(), g_drive, a_drive, g_tau, a_tau,
                      axis, drive, corr)


def with_bias_components(f_cont, g_cont, noise: NoiseModel, at: int):
    """``F``, ``G`` with the further Gauss-Markov components of the flicker biases (``noise.n_extra`` states, in
    ``noise.extra_axis`` order) inserted at state ``at`` (after the INS states, before the odometer and mounting
    ones), each with a noise column of its own. Component k of bias axis i drives the total ``BG``/``BA`` state i by
    ``(1/T_1 - 1/T_k) c_k + q_k w_k`` (module doc)."""
    k = noise.n_extra
    if k == 0:
        return f_cont, g_cont
    n, m = g_cont.shape
    f = np.zeros((n + k, n + k))
    g = np.zeros((n + k, m + k))
    keep = np.r_[0:at, at + k:n + k]
    f[np.ix_(keep, keep)] = f_cont
    g[keep, :m] = g_cont
    main_tau = np.concatenate([noise.gyro_bias_tau, noise.accel_bias_tau])
    for j, (axis, drive, tau) in enumerate(zip(noise.extra_axis, noise.extra_drive, noise.extra_tau)):
        s, total = at + j, BG.start + axis  # BA follows BG: axes 3-5 are BA's
        f[s, s] = -1.0 / tau
        f[total, s] = 1.0 / main_tau[axis] - 1.0 / tau
        g[s, m + j] = g[total, m + j] = drive
    return f, g


def bias_component_covariance(noise: NoiseModel, total_var: np.ndarray) -> np.ndarray:
    """Initial covariance (6 + k, 6 + k) of the total biases ``BG BA`` (their variances ``total_var`` (6,)) and
    their k further components (``noise.n_extra``, in ``noise.extra_axis`` order): each component at its stationary
    variance, its total by as much more, and correlated with it."""
    k = noise.n_extra
    cov = np.zeros((6 + k, 6 + k))
    cov[range(6), range(6)] = total_var
    for j, (axis, drive, tau) in enumerate(zip(noise.extra_axis, noise.extra_drive, noise.extra_tau)):
        var = drive**2 * tau / 2.0
        cov[6 + j, 6 + j] = cov[axis, 6 + j] = cov[6 + j, axis] = var
        cov[axis, axis] += var
    return cov


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
