"""The reference trajectory's own error: a nuisance tied to the motion, separated before sensor physics is blamed.

A truth a user brings (a reference INS, a survey, a CSV from another simulator) is rounded and interpolated; the
simulator turns it into rates and specific forces through a smoothing spline, whose error follows the motion:
(1) on a moving truth file, the specific force carries a slow error (the spline's position error, a few mm at
periods of tens of seconds, times (2 pi f)^2: ~1e-4 m/s^2 on a car), so on those recordings the accelerometer
residual below :data:`REF_CUTOFF_HZ` is a nuisance (its DFT bins are projected out, which only removes power);
(2) spectral lines at harmonics of the trajectory (where the truth's own rate/specific force has a line) are the
reference's error, not vibration; lines below :data:`F_MECH_HZ` are slow periodic wander, not a mechanical source.
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import median_filter

from imu_sim.diagnose.case import trajectory

F_MECH_HZ = 1.0
"""Lowest frequency (Hz) searched for a vibration line: below it no mechanical source of a sensor mount."""
REF_CUTOFF_HZ = 0.2
"""On a moving truth file the accelerometer residual below this (Hz) is the reference's error (a nuisance)."""
FILE_SOURCES = ("trajectory", "gnss_track")
MOVING_MPS = 0.05
"""A truth whose speed exceeds this (m/s) somewhere translates: its spline's position error reaches the
accelerometers."""
HARMONIC_RATIO = 100.0
"""A bin where the truth's rate/specific force has 100x its local median power is a harmonic of the motion."""


def moving_file_truth(case) -> bool:
    """True when the truth comes from a file and the IMU translates (a tumble or a rate table does not)."""
    if getattr(case.scenario, "source", None) not in FILE_SOURCES:
        return False
    if "moving_file_truth" not in case.cache:
        traj = trajectory(case)
        speed = np.linalg.norm(traj.position.enu(case.sim_t_abs, 1), axis=1)
        case.cache["moving_file_truth"] = bool(np.max(speed) > MOVING_MPS)
    return case.cache["moving_file_truth"]


def clean(case, resid: np.ndarray) -> np.ndarray:
    """The residual less its nuisances: each joined file's own turn-on bias (its mean per channel), and on a
    moving truth file the accelerometers' slow part (else unchanged)."""
    resets = list(getattr(case, "bias_resets", None) or [])
    if resets:
        resid = resid.copy()
        for a, b in zip([0] + resets, resets + [len(resid)]):
            resid[a:b] -= resid[a:b].mean(axis=0)
    if not moving_file_truth(case):
        return resid
    spec = np.fft.rfft(resid[:, 3:], axis=0)
    freqs = np.fft.rfftfreq(len(resid), case.dt)
    spec[(freqs > 0) & (freqs < REF_CUTOFF_HZ)] = 0.0  # DC (the turn-on bias) kept: every test drops it anyway
    out = resid.copy()
    out[:, 3:] = np.fft.irfft(spec, n=len(resid), axis=0)
    return out


def harmonic_bins(case) -> np.ndarray:
    """Mask (nf,) of rfft bins at lines of the truth's own rate / specific force (one bin either side)."""
    truth = np.column_stack([case.gyro_true, case.accel_true])
    truth = truth - truth.mean(axis=0)
    nf = len(case.t) // 2 + 1
    if not np.any(np.std(truth, axis=0) > 1e-9):
        return np.zeros(nf, bool)
    power = np.abs(np.fft.rfft(truth, axis=0)) ** 2
    local = median_filter(power, size=(101, 1), mode="nearest")
    ratio = np.max(power / np.maximum(local, 1e-300 + 1e-12 * power.max(axis=0)), axis=1)
    lines = ratio > HARMONIC_RATIO
    lines[0] = False
    return lines | np.r_[lines[1:], False] | np.r_[False, lines[:-1]]


def note(case, n_harmonic: int) -> str:
    """What the vibration test left out, for ``tested``."""
    parts = [f"lines below {F_MECH_HZ:g} Hz are not searched (no mechanical source; slow periodic wander is "
             "tested by the low-frequency effects)"]
    if n_harmonic:
        parts.append(f"{n_harmonic} bins at harmonics of the trajectory's own motion excluded (the reference "
                     "trajectory's error follows the motion)")
    if moving_file_truth(case):
        parts.append(f"accelerometer residual below {REF_CUTOFF_HZ:g} Hz treated as the reference trajectory's "
                     "error (moving truth file)")
    return "; ".join(parts)
