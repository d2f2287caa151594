"""The candidate of one effect's test, the thresholds, the calibration factors and the findings' wording.

A leaf module: every other module of the diagnosis may import it, it imports none of them.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml
from scipy import stats

from nav_core.sensor_model import SensorModel

ALPHA = 0.05
CALIBRATION_FILE = Path(__file__).with_name("calibration.yaml")
FLOOR = 1.0
"""Smallest threshold factor: the calibration never lowers an analytic threshold (see :mod:`calibrate`)."""
GNSS_EFFECTS = ("gps_lever_arm", "gps_latency", "colored_gps_noise")
EXPLAIN = {
    "earth_rotation": "The gyro residual follows the Earth rate rotated into the body frame; the model leaves out "
                      "Earth rotation (15 deg/h times the attitude-dependent projection).",
    "gravity_model": "The accelerometer residual is proportional to the specific force with the size of normal "
                     "gravity at this latitude and height minus 9.80665 m/s^2: the model uses constant gravity.",
    "coriolis": "The residual follows the Coriolis and transport-rate terms of the truth velocity.",
    "gyro_g_sensitivity": "Gyro bias proportional to the specific force on the same axis (g-sensitivity), visible "
                          "because the orientation changes the specific force on each axis.",
    "temperature_bias": "Biases track the logged temperature linearly; the model has no thermal coefficient.",
    "warmup_drift": "Biases decay exponentially after switch-on (warm-up); a constant turn-on bias misses it.",
    "scale_factor": "The residual is proportional to the true rate / specific force on the same axis: a "
                    "scale-factor error the model does not have.",
    "axis_misalignment": "The residual on one axis follows the true rate / specific force on the other axes: "
                         "non-orthogonal or misaligned sensing axes.",
    "vibration": "A spectral line the model does not produce: a sinusoidal vibration (or its alias) in the "
                 "sensor output.",
    "quantization": "The raw values lie on a lattice (a fixed output step); a continuous simulator misses the "
                    "quantization even where the step is smaller than the noise.",
    "gauss_markov_bias": "Excess low-frequency power with a corner: a correlated (Gauss-Markov) bias wander "
                         "beyond the model's noise.",
    "bias_random_walk": "Excess power rising as 1/f^2 at low frequency: a bias random walk beyond the model's "
                        "noise.",
    "gps_latency": "The fix residual follows minus the truth velocity: the fixes are stamped later than the "
                   "position they report (receiver latency).",
    "gps_lever_arm": "The fix residual follows the attitude-rotated body offset: the antenna is not at the IMU "
                     "(lever arm) and the model leaves it out.",
    "colored_gps_noise": "The fix residual has excess low-frequency power with a corner (Gauss-Markov): the "
                         "model's GNSS noise is white but the receiver's error is correlated in time.",
}


CONING_NOTE = ("not identifiable by any scenario of this simulator: the wobble's rectified rate (a^2 W / 2 on "
               "gyro z) and specific force (-a A on accel z) are constant over the run (the effect has no time "
               "window), so they are collinear with the turn-on bias; the wobble itself is a line on gyro x/y, "
               "tested as vibration")


def load_calibration() -> dict:
    """Per-effect threshold factors from the null Monte Carlo (1.0 when not calibrated; never below the floor)."""
    if CALIBRATION_FILE.exists():
        data = yaml.safe_load(CALIBRATION_FILE.read_text()) or {}
        return {k: max(float(v), FLOOR) for k, v in (data.get("factors") or {}).items()}
    return {}


@dataclass
class Candidate:
    """One effect's test: statistic against threshold, fit, and how to add it to the model."""

    effect: str
    stat: float
    threshold: float
    statistic: str
    identifiable: bool = True
    reason: str = ""
    channels: list = field(default_factory=list)
    params: dict = field(default_factory=dict)
    intervals: dict = field(default_factory=dict)
    physics: dict | None = None
    columns: dict | None = None
    contrib: np.ndarray | None = None
    kind: str = "regression"
    block_s: float = 1.0
    band: dict | None = None
    rank: float | None = None
    """Ranking key when it is not statistic - threshold (e.g. a conditional LR of correlated effects)."""
    caveat: str = ""
    """Added to the finding's explanation (e.g. a rival this record cannot tell it from)."""
    constant_scale: float | None = None
    """A known constant's fitted scale on its exact regressor (1 = the constant); None for other effects."""
    constant_se: float | None = None
    """Standard error of ``constant_scale``."""
    refit: object = None
    """For a regression: a function of parameter names returning the candidate refitted without them (None else)."""
    design: object = None
    """For a regression: its :class:`~imu_sim.diagnose.regressors.Design` (physics of a refitted theta)."""
    mounting_theta: object = None
    """On a hand-mounted rate table: each mounting's fitted rotation (rad) from the joint fit, and the statistic alone."""
    stat_alone: float | None = None
    given_rivals: dict = field(default_factory=dict)
    """A slow-wander candidate's statistic given each significant rival in the model (:mod:`ranking`), by effect."""

    @property
    def significant(self) -> bool:
        """Identifiable and above threshold."""
        return self.identifiable and self.stat > self.threshold

    def tested_entry(self) -> dict:
        """What ``tested`` in diagnosis.json lists."""
        return {"effect": self.effect, "statistic": self.statistic, "value": rounded(self.stat),
                "threshold": rounded(self.threshold), "significant": bool(self.significant),
                "identifiable": bool(self.identifiable), "note": self.reason}


def rounded(x):
    """x to 6 significant digits for JSON; None when missing or not finite."""
    return None if x is None or not np.isfinite(x) else float(f"{x:.6g}")


def threshold(dof: int, m_tests: int, grid: int = 1, factor: float = 1.0) -> float:
    """Chi-square(dof) quantile at ALPHA split over m_tests effects and grid points, times a calibration factor."""
    return float(stats.chi2.isf(ALPHA / (m_tests * grid), dof) * factor)


@dataclass
class Context:
    """What every effect's test reads: the case, the model under test, its residual (n, 6) and that residual's
    whitener and DFT, the number of effects tested (Bonferroni) and the calibration factors."""

    case: object
    model: SensorModel
    resid: np.ndarray
    wh: object = None
    resid_f: np.ndarray | None = None
    m_tests: int = 1
    factors: dict = field(default_factory=dict)

    def factor(self, effect: str) -> float:
        """Calibrated threshold factor of ``effect`` (1 when not calibrated)."""
        return self.factors.get(effect, 1.0)


def not_testable(effect: str, why: str) -> Candidate:
    """A candidate the record cannot test, with the reason."""
    return Candidate(effect, np.nan, np.nan, "-", identifiable=False, reason=why)


def add_effect(model: SensorModel, cand: Candidate) -> SensorModel:
    """The model with the candidate's physics entry added."""
    return model.with_physics(cand.effect, **(cand.physics or {}))


def evidence(cand: Candidate) -> float:
    """Ranking key within one pass: statistic minus threshold (or the candidate's own ``rank``)."""
    return cand.rank if cand.rank is not None else cand.stat - cand.threshold
