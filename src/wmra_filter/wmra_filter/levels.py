"""Decomposition level from the sample rate and the motion bandwidth; support of the SWT denoiser.

The undecimated (stationary) transform at level ``J`` splits ``[0, fs/2]`` into
detail bands ``[fs/2^(j+1), fs/2^j]`` (j = 1..J) and the approximation band
``[0, fs/2^(J+1)]``. Only details are thresholded, so the approximation passes
untouched: the level is the deepest one whose approximation band still holds
the whole motion bandwidth, ``J = floor(log2(fs / (2 * bandwidth)))``.
"""
from __future__ import annotations

import functools
import math

import numpy as np
import pywt

VEHICLE_BANDWIDTH_HZ = {
    "rate_table": 5.0,      # paper Fig. 4: rate steps, kept sharp by the thresholds, not by the band
    "road_vehicle": 5.0,    # body motion of a car; engine vibration lies above it
    "rover": 2.0,           # slow planetary/field rovers
    "pedestrian": 15.0,     # foot impacts carry energy to ~15 Hz
    "aircraft": 10.0,       # small UAV manoeuvres
}
"""Default motion bandwidth to keep, Hz, per vehicle class."""


class LevelError(ValueError):
    """The sample rate, bandwidth or level cannot give a valid decomposition."""


def level_for_bandwidth(sample_rate_hz: float, bandwidth_hz: float) -> int:
    """Deepest SWT level whose approximation band [0, fs/2^(J+1)] Hz holds ``bandwidth_hz`` (at least 1)."""
    if not sample_rate_hz > 0 or not bandwidth_hz > 0:
        raise LevelError(f"sample rate {sample_rate_hz!r} Hz and bandwidth {bandwidth_hz!r} Hz must be > 0")
    if bandwidth_hz >= sample_rate_hz / 4:
        raise LevelError(f"bandwidth {bandwidth_hz} Hz leaves no detail band to denoise at "
                         f"{sample_rate_hz} Hz (must be below fs/4 = {sample_rate_hz / 4} Hz)")
    return max(1, int(math.floor(math.log2(sample_rate_hz / (2.0 * bandwidth_hz)))))


def approximation_band_hz(sample_rate_hz: float, level: int) -> float:
    """Upper edge of the untouched approximation band, Hz."""
    return sample_rate_hz / 2 ** (level + 1)


@functools.lru_cache(maxsize=64)
def support(wavelet: str, level: int) -> tuple[int, int]:
    """(left, right) radius in samples: output n of the denoiser depends only on inputs n-left .. n+right.

    Measured from PyWavelets' own impulse responses: an input impulse at p reaches the
    detail coefficients at p + A_j, a detail coefficient at n reaches the outputs at
    n + S_j; thresholding is pointwise, so input p reaches outputs p + A_j + S_j and
    output n depends on inputs n - max(A_j + S_j) .. n - min(A_j + S_j).
    (For db8 this is 15 * (2^level - 1) on each side.)
    """
    step = 2 ** level
    length = step * (pywt.Wavelet(wavelet).dec_len + 2) * 4
    centre = length // 2
    left = right = 0
    for shift in range(step):  # the inverse averages over shifts; take the union over phases
        p = centre + shift
        impulse = np.zeros(length)
        impulse[p] = 1.0
        details = pywt.swt(impulse, wavelet, level=level, trim_approx=True)[1:]
        for j, detail in enumerate(details):
            a_lo, a_hi = _nonzero_span(detail, p)
            coeffs = [np.zeros(length) for _ in range(level + 1)]
            coeffs[j + 1][p] = 1.0
            s_lo, s_hi = _nonzero_span(pywt.iswt(coeffs, wavelet), p)
            left, right = max(left, a_hi + s_hi), max(right, -(a_lo + s_lo))
    return int(left), int(right)


def _nonzero_span(values: np.ndarray, origin: int) -> tuple[int, int]:
    idx = np.flatnonzero(values != 0.0)  # exact zeros: the true support, not a tolerance
    return int(idx[0] - origin), int(idx[-1] - origin)


def min_window(wavelet: str, level: int, hop: int) -> int:
    """Smallest SWT window (samples, a multiple of 2^level) that gives ``hop`` exact outputs per step."""
    left, right = support(wavelet, level)
    need = left + right + hop
    step = 2 ** level
    return -(-need // step) * step
