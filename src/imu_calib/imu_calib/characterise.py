"""Stochastic characterisation of a static recording: Allan deviation per axis, noise fit, sensor model.

The one pipeline behind ``imu-calib allan`` and ``allan_node``:
``characterise(rec) -> Characterisation``, then ``write_outputs(result, out_dir)``
writes ``sensor_model.yaml``, ``imu.yaml`` (Kalibr keys) and ``allan.png``.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from imu_calib.allan import AllanDeviation, AllanError, log_taus, octave_taus, overlapping_adev, psd
from imu_calib.noise_fit import SCHEMA_NAMES, TERMS, fit_noise
from nav_core import sensor_model
from nav_core.recording import ImuRecording

AXIS_NAMES = ("x", "y", "z")
MIN_CLUSTER_TIMES = 6
"""A fit needs at least this many cluster times (13 samples on an octave grid give 6)."""


@dataclass
class Characterisation:
    """Allan deviations and fits per triad and axis, the resulting sensor model."""

    adev: dict
    """Triad -> AllanDeviation with (k, 3) arrays."""
    fits: dict
    """Triad -> list of 3 NoiseFit."""
    model: sensor_model.SensorModel
    white_psd: dict
    """Triad -> (3,) white-noise level from the Welch PSD (unit*sqrt(s))."""


def grid(n_samples: int, rate_hz: float, per_decade: int | None = None) -> np.ndarray:
    """Cluster times, s: octave grid, or ``per_decade`` log-spaced points per decade."""
    taus = octave_taus(n_samples, rate_hz) if not per_decade else log_taus(n_samples, rate_hz, per_decade)
    if len(taus) < MIN_CLUSTER_TIMES:
        raise AllanError(f"recording too short: {n_samples} samples ({n_samples / rate_hz:.4g} s at "
                         f"{rate_hz:g} Hz) give only {len(taus)} cluster times; the noise fit needs at least "
                         f"{MIN_CLUSTER_TIMES} (at least {2 ** MIN_CLUSTER_TIMES} samples)")
    return taus


def check_uniform(rec: ImuRecording, tolerance: float = 0.05) -> float:
    """Sample rate (Hz) of ``rec``; AllanError naming the source if samples are missing or irregular."""
    if len(rec) < 2:
        raise AllanError(f"{rec.source or 'recording'}: {len(rec)} samples, nothing to analyse")
    dt = np.diff(rec.t)
    median = np.median(dt)
    if not median > 0:
        raise AllanError(f"{rec.source}: time stamps do not increase")
    bad = np.abs(dt / median - 1.0) > 0.5
    if bad.mean() > tolerance:
        raise AllanError(f"{rec.source}: {bad.mean():.1%} of sample intervals differ from the median "
                         f"{median:.4g} s by more than half; Allan variance needs uniform sampling")
    # stamps in s carry float noise: 1e-6 Hz resolution is plenty for any IMU rate
    return float(np.round(1.0 / median, 6))


def characterise(rec: ImuRecording, per_decade: int | None = None, taus=None, progress=None,
                 base_model: sensor_model.SensorModel | None = None) -> Characterisation:
    """Allan deviation (overlapping) and five-term fit of the six axes of a static recording.

    ``progress`` is called with a short label after each of the six axes (for tqdm).
    ``base_model`` keeps its deterministic terms (bias, scale, misalignment).
    """
    rate = check_uniform(rec)
    taus = grid(len(rec), rate, per_decade) if taus is None else np.asarray(taus, float)
    model = base_model.copy() if base_model is not None else sensor_model.SensorModel()
    model.sample_rate_hz = rate
    adevs, fits, white = {}, {}, {}
    for triad in ("gyro", "accel"):
        data = getattr(rec, triad)
        per_axis = []
        for i in range(3):
            per_axis.append(overlapping_adev(data[:, i], rate, taus))
            if progress:
                progress(f"{triad} {AXIS_NAMES[i]}")
        adevs[triad] = _stack(per_axis)
        fits[triad] = [fit_noise(a, samples=data[:, i]) for i, a in enumerate(per_axis)]
        white[triad] = psd(data, rate).white_noise
        _write_fits(model.triad(triad), fits[triad], white[triad])
    sensor_model.stamp_provenance(model, "imu_calib allan", rec.source or "<memory>",
                                  n_samples=len(rec), duration_s=float(len(rec) / rate),
                                  estimator="overlapping Allan variance, 5-term IRLS WLS fit and term selection, "
                                            "Whittle likelihood refinement where the model fits")
    return Characterisation(adevs, fits, model, white)


def _stack(per_axis) -> AllanDeviation:
    a = per_axis[0]
    col = (lambda name: np.column_stack([getattr(p, name) for p in per_axis]))
    return AllanDeviation(a.taus, col("adev"), col("lo"), col("hi"), col("edf"), a.n_samples, a.rate_hz,
                          a.confidence, a.overlapping)


def _write_fits(triad, fits, white_psd) -> None:
    """Copy fitted terms and intervals of three axes into a TriadModel."""
    for term in TERMS:
        name = SCHEMA_NAMES[term]
        setattr(triad, name, np.array([f.values[term] for f in fits]))
        triad.intervals[name] = np.array([f.intervals[term] for f in fits])
    triad.bias_correlation_time = np.array([f.bias_correlation_time for f in fits])
    triad.intervals.pop("bias_correlation_time", None)
    triad.info["noise_fit"] = {AXIS_NAMES[i]: f.summary() for i, f in enumerate(fits)}
    triad.info["psd_white_noise"] = [float(v) for v in white_psd]


def write_outputs(result: Characterisation, out_dir, rostopic: str = "/imu/data_raw") -> dict:
    """Write ``sensor_model.yaml``, ``imu.yaml`` (Kalibr) and ``allan.png`` into ``out_dir``; return the paths."""
    from imu_calib.plots import plot_allan

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"sensor_model": sensor_model.save(result.model, out / "sensor_model.yaml"),
             "kalibr": sensor_model.save_kalibr(result.model, out / "imu.yaml", rostopic),
             "plot": plot_allan(result, out / "allan.png")}
    return paths
