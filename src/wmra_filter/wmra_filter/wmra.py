"""Batch WMRA: calibrate, then denoise with the undecimated (stationary) db8 transform.

Why the stationary transform: the decimated DWT is not translation-invariant, so a
sliding window could never reproduce a batch result. The SWT denoiser used here
(``pywt.swt`` -> per-level shrinkage -> inverse SWT) is translation-equivariant and
local: output sample ``n`` depends only on inputs ``n - left .. n + right``
(:func:`wmra_filter.levels.support`; 48 / 42 samples for db8 at level 2). So the
batch result on a record is defined on the record extended at both ends by
repeating its first and last sample (``np.pad(mode="edge")``), and any window that
covers ``n - left .. n + right`` of that extended record gives the same output at
``n``. The *edge region* is the first ``left`` and the last ``right`` samples of a
record (or of a segment between gaps): there the output depends on the repeated end
samples and is less denoised; batch and streaming still agree there.

Arrays are (n, k): rows are samples, columns axes (gyro x y z in rad/s then accel
x y z in m/s^2 for an IMU). Thresholds are (level, k), level 1 (finest) first.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pywt

from nav_core.sensor_model import SensorModel, corrector
from wmra_filter import levels, thresholds as thr

BLOCK = 1 << 16
"""Samples per block of the batch denoiser (memory bound; results do not depend on it)."""


class WmraConfigError(ValueError):
    """An invalid WMRA setting; the message names the setting."""


@dataclass(frozen=True)
class WmraConfig:
    """WMRA settings. Rates in Hz, lengths in samples."""

    sample_rate_hz: float
    level: int
    wavelet: str = "db8"
    mode: str = "hard_soft"
    soft_ratio: float = 0.5
    rule: str = "universal"
    noise: str = "model"
    hop: int = 8
    window: int = 0
    """SWT length per streaming step and the n of the universal threshold; 0 = smallest valid."""

    def __post_init__(self):
        _check_choice("wavelet", self.wavelet, pywt.wavelist(kind="discrete"))
        _check_choice("mode", self.mode, thr.MODES)
        _check_choice("rule", self.rule, thr.RULES)
        _check_choice("noise", self.noise, thr.NOISE_SOURCES)
        if not self.sample_rate_hz > 0:
            raise WmraConfigError(f"sample_rate_hz must be > 0, got {self.sample_rate_hz!r}")
        if not 1 <= int(self.level) <= 12:
            raise WmraConfigError(f"level must be in 1..12, got {self.level!r}")
        if not 0.0 <= self.soft_ratio <= 1.0:
            raise WmraConfigError(f"soft_ratio must be in [0, 1], got {self.soft_ratio!r}")
        if int(self.hop) < 1:
            raise WmraConfigError(f"hop must be >= 1 sample, got {self.hop!r}")
        if self.window:
            need = levels.min_window(self.wavelet, self.level, self.hop)
            if self.window < need or self.window % 2 ** self.level:
                raise WmraConfigError(f"window {self.window} must be a multiple of 2^level = {2 ** self.level} "
                                      f"and >= {need} (support {self.support} + hop {self.hop})")

    @classmethod
    def for_bandwidth(cls, sample_rate_hz: float, bandwidth_hz: float | None = None,
                      vehicle: str = "road_vehicle", **kwargs) -> WmraConfig:
        """Config whose level keeps ``bandwidth_hz`` (default: the vehicle class's) untouched."""
        if bandwidth_hz is None:
            _check_choice("vehicle", vehicle, tuple(levels.VEHICLE_BANDWIDTH_HZ))
            bandwidth_hz = levels.VEHICLE_BANDWIDTH_HZ[vehicle]
        try:
            level = levels.level_for_bandwidth(sample_rate_hz, bandwidth_hz)
        except levels.LevelError as err:
            raise WmraConfigError(str(err)) from err
        return cls(sample_rate_hz=sample_rate_hz, level=level, **kwargs)

    @property
    def support(self) -> tuple[int, int]:
        """(left, right) dependence radius of one output, samples."""
        return levels.support(self.wavelet, self.level)

    @property
    def window_samples(self) -> int:
        """The SWT window actually used, samples."""
        return self.window or levels.min_window(self.wavelet, self.level, self.hop)

    @property
    def delay_samples(self) -> int:
        """Fixed streaming delay, samples: the right support plus the hop minus one."""
        return self.support[1] + self.hop - 1

    @property
    def delay_s(self) -> float:
        """Fixed streaming delay, s."""
        return self.delay_samples / self.sample_rate_hz

    def with_(self, **changes) -> WmraConfig:
        """A copy with ``changes`` (validated)."""
        return replace(self, **changes)


def _check_choice(name, value, choices):
    if value not in choices:
        shown = list(choices) if len(choices) < 12 else f"{len(choices)} names, e.g. db8, sym8, coif4"
        raise WmraConfigError(f"{name} {value!r} is not one of {shown}")


def iswt(coeffs, wavelet) -> np.ndarray:
    """Inverse SWT of ``[cA_J, cD_J, ..., cD_1]`` (each (n, k)), equal to ``pywt.iswt`` along axis 0.

    pywt.iswt loops in Python over the 2^(j-1) shifts of every level (20 ms for
    2048 x 6 at level 6); here all shifts of a level go through one ``pywt.idwt``
    call along a reshaped axis, 2 calls per level.
    """
    out = np.array(coeffs[0], dtype=float)
    n = out.shape[0]
    for j in range(len(coeffs) - 1, 0, -1):
        step = 2 ** (j - 1)
        phases = out.reshape(n // step, step, -1)   # phases[r, first] = out[r * step + first]
        detail = np.asarray(coeffs[len(coeffs) - j]).reshape(n // step, step, -1)
        even = pywt.idwt(phases[0::2], detail[0::2], wavelet, mode="periodization", axis=0)
        odd = pywt.idwt(phases[1::2], detail[1::2], wavelet, mode="periodization", axis=0)
        out = (0.5 * (even + np.roll(odd, 1, axis=0))).reshape(out.shape)
    return out


def swt_details(x: np.ndarray, cfg: WmraConfig) -> list:
    """SWT details of ``x`` (n, k) extended by its edge samples, level 1 first, each (n, k)."""
    left, right = cfg.support
    ext = _pad_to_multiple(np.pad(x, ((left, right), (0, 0)), mode="edge"), 2 ** cfg.level)
    coeffs = pywt.swt(ext, cfg.wavelet, level=cfg.level, trim_approx=True, axis=0)
    return [d[left:left + len(x)] for d in reversed(coeffs[1:])]


def _pad_to_multiple(x: np.ndarray, multiple: int) -> np.ndarray:
    extra = -len(x) % multiple
    return np.pad(x, ((0, extra), (0, 0)), mode="edge") if extra else x


def denoise_span(seg: np.ndarray, cfg: WmraConfig, thresholds: np.ndarray) -> np.ndarray:
    """The local denoiser on one span (m, k); exact at rows ``left .. m - 1 - right``."""
    m = len(seg)
    coeffs = pywt.swt(_pad_to_multiple(seg, 2 ** cfg.level), cfg.wavelet, level=cfg.level,
                      trim_approx=True, axis=0)
    level_of = range(cfg.level, 0, -1)  # coeffs[1:] run from level J down to 1
    shrunk = [coeffs[0]] + [thr.shrink(d, thresholds[j - 1], cfg.mode, cfg.soft_ratio)
                            for d, j in zip(coeffs[1:], level_of)]
    return iswt(shrunk, cfg.wavelet)[:m]


def denoise(x: np.ndarray, cfg: WmraConfig, thresholds: np.ndarray) -> np.ndarray:
    """Batch WMRA of a uniformly sampled record ``x`` (n, k) with ``thresholds`` (level, k); same units."""
    x = np.asarray(x, dtype=float)
    squeeze = x.ndim == 1
    x = x.reshape(len(x), -1)
    thresholds = np.broadcast_to(np.asarray(thresholds, dtype=float), (cfg.level, x.shape[1]))
    left, right = cfg.support
    ext = np.pad(x, ((left, right), (0, 0)), mode="edge")
    out = np.empty_like(x)
    for start in range(0, len(x), BLOCK):
        stop = min(start + BLOCK, len(x))
        # ext row (i + left) is x row i; rows start .. stop-1 need ext start .. stop-1+left+right
        out[start:stop] = denoise_span(ext[start:stop + left + right], cfg, thresholds)[left:left + stop - start]
    return out[:, 0] if squeeze else out


def estimate_thresholds(cfg: WmraConfig, sample_sigma=None, x: np.ndarray | None = None) -> np.ndarray:
    """Thresholds (level, k) by ``cfg.noise`` and ``cfg.rule``.

    ``sample_sigma`` (k,): per-sample white-noise sigma for ``noise="model"``; ``x`` (n, k):
    the data, needed for ``noise="mad"`` and for ``rule="sure"``.
    """
    details = None if x is None else swt_details(np.asarray(x, dtype=float).reshape(len(x), -1), cfg)
    if cfg.noise == "model":
        if sample_sigma is None:
            raise WmraConfigError("noise='model' needs the per-sample white-noise sigma")
        sigmas = thr.model_level_sigmas(sample_sigma, cfg.wavelet, cfg.level)
    else:
        if details is None:
            raise WmraConfigError("noise='mad' needs data to estimate the noise from")
        sigmas = thr.mad_level_sigmas(details)
    if cfg.rule == "universal":
        return thr.universal(sigmas, cfg.window_samples)
    if details is None:
        raise WmraConfigError("rule='sure' needs data to estimate the risk from")
    return thr.sure(details, sigmas)


def model_sample_sigma(model: SensorModel, sample_rate_hz: float) -> np.ndarray:
    """Per-sample white-noise sigma (6,) of gyro (rad/s) then accel (m/s^2) from the sensor model's N."""
    density = np.concatenate([model.gyro.white_noise, model.accel.white_noise])
    return thr.white_noise_sigma(density, sample_rate_hz)


def calibrate(gyro: np.ndarray, accel: np.ndarray, model: SensorModel) -> np.ndarray:
    """Deterministic correction (bias, scale, misalignment) -> (n, 6): gyro rad/s then accel m/s^2."""
    return np.hstack([np.atleast_2d(model.gyro.correct(gyro)), np.atleast_2d(model.accel.correct(accel))])


class Calibrator:
    """:func:`calibrate` for one sample at a time: (3,) gyro rad/s, (3,) accel m/s^2 -> (6,)."""

    def __init__(self, model: SensorModel):
        self._gyro, self._accel = corrector(model.gyro), corrector(model.accel)

    def __call__(self, gyro, accel) -> np.ndarray:
        return np.concatenate([self._gyro(gyro), self._accel(accel)], axis=-1)


@dataclass
class WmraResult:
    """Batch output: ``gyro`` (n, 3) rad/s and ``accel`` (n, 3) m/s^2 calibrated and denoised."""

    gyro: np.ndarray
    accel: np.ndarray
    calibrated: np.ndarray
    """(n, 6) calibrated, not denoised."""
    thresholds: np.ndarray
    """(level, 6) thresholds used, SI units of each axis."""
    config: WmraConfig


def denoise_imu(gyro: np.ndarray, accel: np.ndarray, model: SensorModel, cfg: WmraConfig,
                thresholds: np.ndarray | None = None) -> WmraResult:
    """Calibrate with ``model``, then batch WMRA; thresholds from ``cfg`` unless given."""
    calibrated = calibrate(gyro, accel, model)
    if thresholds is None:
        sigma = model_sample_sigma(model, cfg.sample_rate_hz) if cfg.noise == "model" else None
        thresholds = estimate_thresholds(cfg, sigma, calibrated)
    out = denoise(calibrated, cfg, thresholds)
    return WmraResult(out[:, :3], out[:, 3:], calibrated, np.asarray(thresholds), cfg)
