"""Sensor grades (parameter ranges from datasheets and physics) and the error model applied to truth.

measured = (I + diag(sf) + misalignment) @ true + turn-on bias + physical effects + noise, per triad,
the convention of ``nav_core.sensor_model`` (misalignment[i, j]: true axis j seen on axis i).
Noise: white (N / sqrt(dt) per sample), flicker (one-sided PSD B^2/(pi f): Allan plateau 0.664 B),
rate random walk (K sqrt(dt) steps), Gauss-Markov, and per-sample rounding to an LSB (consumer parts).
"""
import numpy as np
from scipy.signal import lfilter

DEG = np.pi / 180.0
DPH = DEG / 3600.0          # deg/h in rad/s
DPRH = DEG / 60.0           # deg/sqrt(h) in rad/sqrt(s)
UG = 9.80665e-6             # micro-g in m/s^2
G0 = 9.80665

# Each range is (low, high), drawn log-uniformly. Sources: typical datasheets of each class
# (navigation: RLG/FOG INS, e.g. 0.002 deg/sqrt(h), 0.003 deg/h; tactical: HG1700/ADIS1649x class;
# industrial: ADIS1646x/Epson G-series; consumer: MPU-6050/BMI160/ICM-20948).
GRADES = {
    "navigation": dict(
        gyro_white=(0.001 * DPRH, 0.003 * DPRH), gyro_flicker=(0.002 * DPH, 0.01 * DPH),
        gyro_rrw=(5e-12, 5e-11), accel_white=(5 * UG, 25 * UG), accel_flicker=(5 * UG, 25 * UG),
        accel_rrw=(1e-7, 1e-6), gyro_sf=(1e-6, 1e-5), accel_sf=(1e-5, 1e-4), misalign=(5e-6, 3e-5),
        g_sens=(0.0002 * DPH / G0, 0.002 * DPH / G0), gyro_temp=(0.001 * DPH, 0.005 * DPH),
        accel_temp=(1 * UG, 5 * UG), gyro_bias_rep=(0.005 * DPH, 0.02 * DPH), accel_bias_rep=(10 * UG, 50 * UG),
        gyro_lsb=None, accel_lsb=None),
    "tactical": dict(
        gyro_white=(0.05 * DPRH, 0.3 * DPRH), gyro_flicker=(0.3 * DPH, 3 * DPH), gyro_rrw=(5e-9, 5e-8),
        accel_white=(30 * UG, 100 * UG), accel_flicker=(10 * UG, 100 * UG), accel_rrw=(5e-6, 3e-5),
        gyro_sf=(5e-5, 3e-4), accel_sf=(1e-4, 5e-4), misalign=(5e-5, 5e-4),
        g_sens=(0.5 * DPH / G0, 3 * DPH / G0), gyro_temp=(0.02 * DPH, 0.2 * DPH), accel_temp=(5 * UG, 30 * UG),
        gyro_bias_rep=(1 * DPH, 10 * DPH), accel_bias_rep=(100 * UG, 1000 * UG), gyro_lsb=None, accel_lsb=None),
    "industrial": dict(
        gyro_white=(0.15 * DPRH, 0.6 * DPRH), gyro_flicker=(2 * DPH, 10 * DPH), gyro_rrw=(3e-8, 3e-7),
        accel_white=(30 * UG, 150 * UG), accel_flicker=(10 * UG, 100 * UG), accel_rrw=(1e-5, 6e-5),
        gyro_sf=(1e-4, 3e-3), accel_sf=(1e-4, 3e-3), misalign=(1e-4, 2e-3),
        g_sens=(5 * DPH / G0, 30 * DPH / G0), gyro_temp=(0.1 * DPH, 1 * DPH), accel_temp=(10 * UG, 100 * UG),
        gyro_bias_rep=(10 * DPH, 100 * DPH), accel_bias_rep=(1e-3 * G0, 5e-3 * G0), gyro_lsb=None, accel_lsb=None),
    "consumer": dict(
        gyro_white=(0.005 * DEG, 0.015 * DEG), gyro_flicker=(10 * DPH, 50 * DPH), gyro_rrw=(3e-7, 3e-6),
        accel_white=(75 * UG, 400 * UG), accel_flicker=(40 * UG, 300 * UG), accel_rrw=(5e-5, 3e-4),
        gyro_sf=(3e-3, 3e-2), accel_sf=(3e-3, 3e-2), misalign=(2e-3, 2e-2),
        g_sens=(0.01 * DEG / G0, 0.1 * DEG / G0), gyro_temp=(0.005 * DEG, 0.03 * DEG),
        accel_temp=(0.1e-3 * G0, 1e-3 * G0),
        gyro_bias_rep=(0.5 * DEG, 3 * DEG), accel_bias_rep=(20e-3 * G0, 80e-3 * G0),
        gyro_lsb=(250 / 32768 * DEG, 1000 / 32768 * DEG), accel_lsb=(2 * G0 / 32768, 8 * G0 / 32768)),
}
GRADE_ORDER = ("navigation", "tactical", "industrial", "consumer")


def draw(rng, rng_range, size=None):
    """Log-uniform draw(s) in ``rng_range`` = (low, high); None stays None."""
    if rng_range is None:
        return None
    lo, hi = rng_range
    return np.exp(rng.uniform(np.log(lo), np.log(hi), size))


def signed(rng, rng_range, size=3):
    """Log-uniform magnitudes with random signs."""
    return draw(rng, rng_range, size) * rng.choice([-1.0, 1.0], size)


def draw_triads(rng, grade: str) -> dict:
    """True error terms of one sensor of ``grade``: per triad dict of SI arrays."""
    g = GRADES[grade]
    out = {}
    for tri in ("gyro", "accel"):
        mis = signed(rng, g["misalign"], (3, 3))
        np.fill_diagonal(mis, 0.0)
        out[tri] = dict(white=draw(rng, g[f"{tri}_white"], 3), flicker=draw(rng, g[f"{tri}_flicker"], 3),
                        rrw=draw(rng, g[f"{tri}_rrw"], 3), sf=signed(rng, g[f"{tri}_sf"]), mis=mis,
                        bias_rep=signed(rng, g[f"{tri}_bias_rep"]),
                        lsb=None if g[f"{tri}_lsb"] is None else float(draw(rng, g[f"{tri}_lsb"])))
    return out


def flicker_noise(rng, n, dt, b):
    """Flicker (1/f) noise, shape (n, 3): one-sided PSD b^2/(pi f) above 1/(n dt), per column b."""
    f = np.fft.rfftfreq(n, dt)
    shape = np.zeros_like(f)
    shape[1:] = np.sqrt(1.0 / (np.pi * f[1:]) * 0.5 / dt)  # white of unit variance has PSD 2 dt
    out = np.empty((n, 3))
    for i in range(3):
        out[:, i] = np.fft.irfft(np.fft.rfft(rng.standard_normal(n)) * shape, n) * b[i]
    return out


def gauss_markov(rng, n, dt, sigma, tau):
    """First-order Gauss-Markov sequence, shape (n, 3): steady sigma, correlation time tau (s), per column."""
    out = np.empty((n, 3))
    for i in range(3):
        phi = np.exp(-dt / tau[i])
        w = rng.standard_normal(n) * sigma[i] * np.sqrt(1 - phi**2)
        w[0] = rng.standard_normal() * sigma[i]
        out[:, i] = lfilter([1.0], [1.0, -phi], w)
    return out


def noise(rng, n, dt, terms) -> np.ndarray:
    """White + flicker + rate random walk of one triad, shape (n, 3)."""
    out = rng.standard_normal((n, 3)) * terms["white"] / np.sqrt(dt)
    out += flicker_noise(rng, n, dt, terms["flicker"])
    out += np.cumsum(rng.standard_normal((n, 3)) * terms["rrw"] * np.sqrt(dt), axis=0)
    return out


def apply_triad(true, terms, bias) -> np.ndarray:
    """Deterministic part: (I + diag(sf) + mis) @ true + bias, shape (n, 3)."""
    mat = np.eye(3) + np.diag(terms["sf"]) + terms["mis"]
    return true @ mat.T + bias


def quantize(x, lsb):
    """Per-sample rounding to the output LSB (a rate-output part; no carry between samples)."""
    return x if lsb is None else np.round(x / lsb) * lsb


def sine_interval_means(t_end, dt, freq_hz, phase):
    """Mean of sin(2 pi f t + phase) over each interval (t - dt, t]."""
    w = 2 * np.pi * freq_hz
    return (np.cos(w * (t_end - dt) + phase) - np.cos(w * t_end + phase)) / (w * dt)
