"""Error-state Kalman steps on FilterPy: van Loan discretization, predict, Joseph-form update with a chi-square gate."""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from filterpy.common import van_loan_discretization
from filterpy.kalman import predict as kf_predict
from filterpy.kalman import update as kf_update
from scipy.stats import chi2


@dataclass
class Correction:
    """Outcome of one measurement: error-state estimate ``dx`` (None if rejected), NIS, its gate, dof."""

    dx: np.ndarray | None
    nis: float
    gate: float
    dof: int
    innovation: np.ndarray

    @property
    def accepted(self) -> bool:
        """Whether the measurement passed the gate and was applied."""
        return self.dx is not None


def propagate(cov, f_cont, g_cont, dt):
    """Covariance (15, 15) propagated over ``dt`` s for x' = F x + G w (unit white w); symmetrised."""
    phi, q = van_loan_discretization(f_cont, g_cont, dt)
    _, cov = kf_predict(np.zeros(len(cov)), cov, phi, q)
    return 0.5 * (cov + cov.T)


@lru_cache(maxsize=64)
def gate_threshold(dof: int, probability: float) -> float:
    """Chi-square quantile for the innovation gate."""
    return float(chi2.ppf(probability, dof))


def correct(cov, z, h, r, probability):
    """Joseph-form update of the zero error state with innovation ``z`` (m,) = predicted - measured.

    Returns the new covariance (unchanged when gated out) and a :class:`Correction`.
    The error state is zero before the update, so the innovation equals ``-z``
    in filterpy's ``z - H x`` convention with a measurement of ``-z``.
    """
    s = h @ cov @ h.T + r
    nis = float(z @ np.linalg.solve(s, z))
    gate = gate_threshold(len(z), probability)
    if not np.isfinite(nis) or nis > gate:
        return cov, Correction(None, nis, gate, len(z), z)
    dx, cov_new = kf_update(np.zeros(len(cov)), cov, z, r, h)
    return 0.5 * (cov_new + cov_new.T), Correction(dx, nis, gate, len(z), z)
