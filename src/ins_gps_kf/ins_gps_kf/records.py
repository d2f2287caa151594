"""What the filter takes and gives: a fix in the local frame, the estimate at an epoch, the event counts."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

WAITING, ALIGNING, HEADING_PENDING, NAVIGATING = "waiting_for_fix", "aligning", "heading_pending", "navigating"
"""The filter's states: no datum yet, aligning, navigating with the heading still to come from the course, navigating."""
STATUS_CODES = {WAITING: 0, ALIGNING: 1, HEADING_PENDING: 2, NAVIGATING: 3}


@dataclass
class Fix:
    """A valid GPS fix in the local frame: stamp (s), ENU position (m), covariance (3, 3) m^2; whether its std
    was given (False: unknown, the default taken)."""

    t: float
    enu: np.ndarray
    cov: np.ndarray
    std_known: bool = True


@dataclass
class Estimate:
    """Filter output at one epoch: SI, ENU position (m, local frame) and velocity, body-to-ENU quaternion."""

    t: float
    position_n: np.ndarray
    velocity_n: np.ndarray
    quat_xyzw: np.ndarray
    cov: np.ndarray
    gyro_bias: np.ndarray
    accel_bias: np.ndarray
    status: str
    gps_used: bool
    zupt_used: bool
    nis: float
    stationary: bool
    scale_factors: np.ndarray | None = None  # gyro then accel (6,), unitless, with estimate_scale_factors
    angular_rate_b: np.ndarray | None = None  # mean bias-corrected body rate over the epoch (3,), rad/s
    predicted_position_n: np.ndarray | None = None  # INS position before this epoch's updates, m (odom chain)
    predicted_quat_xyzw: np.ndarray | None = None  # INS attitude before this epoch's updates


@dataclass
class Counters:
    """Event counts reported in diagnostics."""

    fixes: int = 0
    fixes_invalid: int = 0
    fixes_rejected: int = 0
    fixes_reused: int = 0
    zupts: int = 0
    nhc_updates: int = 0   # non-holonomic constraints applied
    nhc_rejected: int = 0  # constraints the gate refused (a skid, or a vehicle they do not fit)
    odometer_updates: int = 0   # wheel speeds applied
    odometer_rejected: int = 0  # wheel speeds the gate refused (a slipping wheel)
    odometer_gaps: int = 0  # epochs starting a run without a wheel speed within odometer_max_age_s (NHC alone)
    resets: int = 0
    gps_resets: int = 0
    gaps_bridged: int = 0
    epochs: int = 0
    reset_reasons: list = field(default_factory=list)
