"""Evidence: simulated rate-table and road runs, the real car recording, and the figures of merit.

The project simulator (imu_sim) was written concurrently, so the clean signals and
the white noise are generated here: piecewise-constant rate steps (the paper's
Fig. 4) and smooth road dynamics with sharp transitions (Fig. 5), with the white
noise of a BP3010-grade unit (N_gyro 8.7e-4 rad/sqrt(s), N_accel 1.2e-3 m/s/sqrt(s)).

Figures of merit (per channel): SNR in dB, ``10 log10(var(clean) / mean((x - clean)^2))``;
RMS error against the clean signal; and per step transition the 10-90 % rise time
(s) and the overshoot (% of the step height). A zero-phase 4th-order Butterworth
low-pass at the same motion bandwidth (``scipy.signal.sosfiltfilt``) is the linear
peer every figure is compared with.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import signal

from nav_core.recording import ImuRecording
from nav_core.sensor_model import SensorModel, TriadModel
from nav_core.units import DEG, G0
from wmra_filter.wmra import WmraConfig, denoise_imu

N_GYRO = 8.7e-4
"""BP3010-grade gyro white noise (angle random walk), rad/sqrt(s)."""
N_ACCEL = 1.2e-3
"""BP3010-grade accel white noise (velocity random walk), m/s/sqrt(s)."""
CHANNELS = ("gx", "gy", "gz", "ax", "ay", "az")


@dataclass
class Scenario:
    """A simulated run: ``t`` (n,) s, ``clean`` and ``noisy`` (n, 6) gyro rad/s then accel m/s^2."""

    name: str
    t: np.ndarray
    clean: np.ndarray
    noisy: np.ndarray
    sample_rate_hz: float
    steps: list = field(default_factory=list)
    """(channel index, time s) of each sharp transition."""


def bp3010_model(sample_rate_hz: float = 64.0) -> SensorModel:
    """A sensor model with only the BP3010-grade white noise (no deterministic errors)."""
    return SensorModel(gyro=TriadModel(white_noise=np.full(3, N_GYRO)),
                       accel=TriadModel(white_noise=np.full(3, N_ACCEL)), sample_rate_hz=sample_rate_hz,
                       provenance={"tool": "wmra_filter.evaluation", "source": "BP3010-grade white noise"})


def add_white_noise(clean: np.ndarray, sample_rate_hz: float, rng, n_gyro=N_GYRO, n_accel=N_ACCEL) -> np.ndarray:
    """``clean`` (n, 6) plus white noise of densities N (rad/sqrt(s), m/s/sqrt(s)): sigma = N sqrt(fs)."""
    sigma = np.repeat([n_gyro, n_accel], 3) * np.sqrt(sample_rate_hz)
    return clean + rng.normal(size=clean.shape) * sigma


def rate_table_run(rng, sample_rate_hz=64.0, hold_s=8.0, rates_dps=(0, 10, 30, -20, 50, 5, 0)) -> Scenario:
    """Fig. 4: a level unit on a rate table, z rate stepping through ``rates_dps`` (deg/s), each held ``hold_s``."""
    n_hold = int(round(hold_s * sample_rate_hz))
    t = np.arange(n_hold * len(rates_dps)) / sample_rate_hz
    clean = np.zeros((len(t), 6))
    clean[:, 2] = np.repeat(np.asarray(rates_dps, dtype=float) * DEG, n_hold)
    clean[:, 5] = G0
    steps = [(2, t[i * n_hold]) for i in range(1, len(rates_dps)) if rates_dps[i] != rates_dps[i - 1]]
    return Scenario("rate_table", t, clean, add_white_noise(clean, sample_rate_hz, rng), sample_rate_hz, steps)


def road_run(rng, sample_rate_hz=64.0, duration_s=120.0) -> Scenario:
    """Fig. 5: smooth road dynamics (< 2 Hz) with sharp transitions: brake/throttle steps, turn-in, a pothole."""
    t = np.arange(int(round(duration_s * sample_rate_hz))) / sample_rate_hz
    clean = np.zeros((len(t), 6))
    smooth = _smooth_motion(rng, t, (0.03, 0.6))
    clean[:, 0] = 0.02 * smooth[0]                       # roll rate, rad/s
    clean[:, 1] = 0.02 * smooth[1]                       # pitch rate, rad/s
    clean[:, 2] = 0.08 * smooth[2]                       # yaw rate, rad/s
    clean[:, 3] = 0.6 * smooth[3]                        # longitudinal, m/s^2
    clean[:, 4] = 0.4 * smooth[4]                        # lateral, m/s^2
    clean[:, 5] = G0 + 0.15 * smooth[5]                  # vertical, m/s^2
    steps = []
    for (channel, start, stop, size) in ((3, 15.0, 21.0, -3.5), (3, 40.0, 46.0, 2.0), (2, 60.0, 68.0, 0.35),
                                         (2, 85.0, 90.0, -0.30), (5, 100.0, 100.5, 2.5)):
        box = (t >= start) & (t < stop)
        clean[box, channel] += size
        steps += [(channel, start), (channel, stop)]
    if len(t) and t[-1] < 100.5:
        steps = [s for s in steps if s[1] < t[-1]]
    return Scenario("road", t, clean, add_white_noise(clean, sample_rate_hz, rng), sample_rate_hz, steps)


def _smooth_motion(rng, t, band_hz) -> np.ndarray:
    """Six unit-RMS random sums of sinusoids with frequencies in ``band_hz``, shape (6, n)."""
    freqs = rng.uniform(*band_hz, size=(6, 8))
    phases = rng.uniform(0, 2 * np.pi, size=(6, 8))
    amps = 1.0 / np.sqrt(freqs)  # more slow motion than fast
    out = np.einsum("ck,ckn->cn", amps, np.sin(2 * np.pi * freqs[:, :, None] * t + phases[:, :, None]))
    return out / np.std(out, axis=1, keepdims=True)


def snr_db(clean: np.ndarray, x: np.ndarray) -> np.ndarray:
    """SNR per column, dB: variance of the clean signal over the mean squared error."""
    err = np.mean((np.asarray(x) - clean) ** 2, axis=0)
    power = np.var(clean, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(np.ptp(clean, axis=0) > 0, 10.0 * np.log10(power / err), np.nan)  # nan: a constant channel


def rms_error(clean: np.ndarray, x: np.ndarray) -> np.ndarray:
    """RMS error per column against the clean signal (same unit)."""
    return np.sqrt(np.mean((np.asarray(x) - clean) ** 2, axis=0))


def step_response(t: np.ndarray, y: np.ndarray, clean: np.ndarray, t_step: float, before: float, after: float,
                  window_s: float = 2.0, rise_window_s: float = 0.5) -> tuple[float, float]:
    """(10-90 % rise time s, overshoot % of the step) of ``y`` around a step at ``t_step`` from ``before`` to ``after``.

    Rise: from the last sample below 10 % to the first at or above 90 %, searched
    from ``rise_window_s`` before the step (so a noisy raw signal gives its real, short
    rise and slow road motion before the step does not count).
    Overshoot: the largest excess of ``y`` over the ``clean`` signal in the step's
    direction during ``window_s`` after it (the clean road signal keeps moving).
    """
    box = (t >= t_step - window_s) & (t < t_step + window_s)
    size = after - before
    tt, u = t[box], (y[box] - before) / size
    above = np.flatnonzero((u >= 0.9) & (tt >= t_step - rise_window_s))
    if not len(above):
        return np.inf, 0.0
    i90 = above[0]
    below = np.flatnonzero(u[:i90] < 0.1)
    if not len(below):
        return np.inf, 0.0  # no clean start of the transition in view: not measurable
    i10 = below[-1]
    excess = (y[box] - clean[box]) / size
    overshoot = 100.0 * max(0.0, float(np.max(excess[tt >= t_step])))
    return float(tt[i90] - tt[i10]), overshoot


def lowpass(x: np.ndarray, sample_rate_hz: float, bandwidth_hz: float) -> np.ndarray:
    """The linear peer: zero-phase 4th-order Butterworth low-pass at ``bandwidth_hz``, per column."""
    sos = signal.butter(4, bandwidth_hz, fs=sample_rate_hz, output="sos")
    return signal.sosfiltfilt(sos, x, axis=0)


def evaluate(scenario: Scenario, cfg: WmraConfig, bandwidth_hz: float = 5.0) -> dict:
    """Raw, WMRA and low-pass figures of merit for a simulated run (see module doc)."""
    model = bp3010_model(scenario.sample_rate_hz)
    res = denoise_imu(scenario.noisy[:, :3], scenario.noisy[:, 3:], model, cfg)
    outputs = {"raw": scenario.noisy, "wmra": np.hstack([res.gyro, res.accel]),
               "lowpass": lowpass(scenario.noisy, scenario.sample_rate_hz, bandwidth_hz)}
    # the ends are the edge region of both filters: score the interior
    margin = max(cfg.support)
    inner = slice(margin, len(scenario.t) - margin)
    out = {"scenario": scenario.name, "config": cfg, "outputs": outputs, "thresholds": res.thresholds,
           "snr_db": {}, "rms": {}, "steps": []}
    for name, x in outputs.items():
        out["snr_db"][name] = snr_db(scenario.clean[inner], x[inner])
        out["rms"][name] = rms_error(scenario.clean[inner], x[inner])
    dt = 1.0 / scenario.sample_rate_hz
    for channel, t_step in scenario.steps:
        i = int(np.searchsorted(scenario.t, t_step))
        before, after = scenario.clean[i - 1, channel], scenario.clean[i, channel]
        row = {"channel": CHANNELS[channel], "t": float(t_step), "size": float(after - before)}
        for name, x in outputs.items():
            rise, over = step_response(scenario.t, x[:, channel], scenario.clean[:, channel],
                                       t_step - dt / 2, before, after)
            row[f"rise_{name}_s"], row[f"overshoot_{name}_pct"] = rise, over
        out["steps"].append(row)
    return out


def evaluate_real(rec: ImuRecording, cfg: WmraConfig, bandwidth_hz: float = 5.0) -> dict:
    """No truth: denoise with data-estimated thresholds; the residual (raw - denoised) and its spectrum."""
    model = SensorModel(sample_rate_hz=cfg.sample_rate_hz)  # no calibration known for this unit
    res = denoise_imu(rec.gyro, rec.accel, model, cfg)
    raw = np.hstack([rec.gyro, rec.accel])
    denoised = np.hstack([res.gyro, res.accel])
    residual = raw - denoised
    freqs, psd = signal.welch(residual, fs=cfg.sample_rate_hz, nperseg=512, axis=0)
    _, psd_raw = signal.welch(raw - raw.mean(axis=0), fs=cfg.sample_rate_hz, nperseg=512, axis=0)
    in_band = freqs <= bandwidth_hz
    return {"raw": raw, "denoised": denoised, "residual": residual, "freqs": freqs, "psd_residual": psd,
            "psd_raw": psd_raw, "thresholds": res.thresholds, "residual_std": residual.std(axis=0),
            "residual_power_in_band": psd[in_band].sum(axis=0) / psd.sum(axis=0),
            "raw_power_removed": residual.var(axis=0) / raw.var(axis=0)}
