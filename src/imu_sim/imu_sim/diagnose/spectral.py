"""Generalised least squares by frequency-domain whitening with the model's noise PSD.

A stationary noise with two-sided PSD S(f) has a covariance that the DFT nearly
diagonalises, so weighting each DFT bin by 1/S(f) is GLS (the Whittle
approximation). The DC bin is dropped: that makes the constant turn-on bias of
every channel a nuisance parameter, always in the base model. The PSD level is
rescaled per channel by a robust estimate (median of the whitened periodogram), so
a model whose noise level is off does not inflate the statistics.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from nav_core import noise_stats
from nav_core.sensor_model import SensorModel

from imu_sim.diagnose.case import effective_model

SE_MAX = 1.0
"""A scale factor, misalignment, g-sensitivity or physical scale whose standard error exceeds this is not
identifiable by the run (its natural scale is 1; callers pass it as ``se_max``)."""


def noise_psd(model: SensorModel, freqs: np.ndarray, dt: float) -> np.ndarray:
    """Two-sided PSD (unit^2/Hz) of the model's noise (physics overrides applied) per channel, shape (6, nf)."""
    return noise_stats.noise_psd(effective_model(model), freqs)


class Whitener(noise_stats.Whitener):
    """:class:`nav_core.noise_stats.Whitener` of the model the simulator uses (physics overrides applied)."""

    @classmethod
    def from_model(cls, model: SensorModel, resid: np.ndarray, dt: float) -> Whitener:
        """Weights from ``model``'s PSD; scales from the median whitened periodogram of ``resid`` (n, 6)."""
        return super().from_model(effective_model(model), resid, dt)

    unstated = None
    """(n,) mask of samples with no reference (a static-segment record's moves, :func:`reference.unstated_moves`):
    every regressor is 0 there, so the residual's fill carries no information into any fit."""

    def spectrum(self, x: np.ndarray) -> np.ndarray:
        """rfft along time of x (n,) or (n, k), zero where the record has no reference."""
        if self.unstated is not None and len(x) == len(self.unstated):
            x = np.where(self.unstated[:, None] if x.ndim == 2 else self.unstated, 0.0, x)
        return super().spectrum(x)


@dataclass
class GlsResult:
    """Parameters, covariance, likelihood-ratio statistic (chi-square under the null) and identifiability."""

    theta: np.ndarray
    cov: np.ndarray
    lr: float
    dof: int
    identifiable: bool
    why: str = ""
    dropped: list = field(default_factory=list)
    """Parameters whose regressor is constant (or absent) over the run: the others may still be testable."""

    def interval(self, z: float = 1.959964) -> np.ndarray:
        """95 % intervals (k, 2)."""
        sd = np.sqrt(np.clip(np.diag(self.cov), 0, None))
        return np.column_stack([self.theta - z * sd, self.theta + z * sd])


def gls(wh: Whitener, resid_f: np.ndarray, design: dict, k: int, se_max: float | None = None) -> GlsResult:
    """Joint GLS of residual spectra (nf, 6) on a design {channel: (n, k) columns}; LR = b^T A^-1 b.

    ``se_max``: a parameter whose marginal standard error exceeds it is dropped as not identifiable (for
    parameters with a natural scale, e.g. a scale factor: +-1 says nothing)."""
    a = np.zeros((k, k))
    b = np.zeros(k)
    raw = np.zeros(k)
    ac = np.zeros(k)
    for ch, x in design.items():
        used = np.flatnonzero(np.any(x != 0, axis=0))
        if len(used) == 0:
            continue
        xu = x[:, used]
        xf = wh.spectrum(xu)
        a[np.ix_(used, used)] += wh.gram(ch, xf, xf)
        b[used] += wh.gram(ch, xf, resid_f[:, ch])
        raw[used] += np.sum(xu**2, axis=0)
        ac[used] += np.sum((xu - xu.mean(axis=0)) ** 2, axis=0)
    frac = ac / np.maximum(raw, 1e-300)
    # a parameter the run determines no better than +-1 (SI; e.g. a scale factor from a regressor that is
    # round-off, an axis that never turns) is not identifiable either
    weak = np.diag(a) < 1.0 / se_max**2 if se_max else np.zeros(k, bool)
    if np.any(frac < 1e-10) or np.any(weak):
        result = GlsResult(np.zeros(k), np.full((k, k), np.nan), 0.0, k, False,
                           "its regressor is constant over the run here (so it is collinear with the turn-on bias) "
                           "or too weak to determine (standard error above the parameter's natural scale)")
        result.dropped = [int(j) for j in np.flatnonzero((frac < 1e-10) | weak)]
        return result
    d = np.sqrt(np.diag(a))
    corr = a / np.outer(d, d)
    if np.linalg.eigvalsh(corr).min() < 1e-8:
        return GlsResult(np.zeros(k), np.full((k, k), np.nan), 0.0, k, False,
                         "its regressors are collinear with each other or with the bias in this scenario")
    cov = np.linalg.inv(a)
    theta = cov @ b
    return GlsResult(theta, cov, float(b @ theta), k, True)
