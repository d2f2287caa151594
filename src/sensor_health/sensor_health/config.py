"""The health monitor's settings and its per-window trace for the plot (SI units; no ROS)."""
from __future__ import annotations

from dataclasses import dataclass, field

from nav_core.units import deg2rad, g2mps2


@dataclass
class HealthConfig:
    """Monitor settings (SI units)."""

    window_s: float = 1.0
    f_min_hz: float = 2.0
    """Lines are searched from here to Nyquist (the vehicle's motion lives below)."""
    false_alarms_per_10h: float = 0.3
    """Budget of statistical false events on the model's own noise, all detectors and channels together."""
    baseline_s: float = 600.0
    """Time constant of the bias baseline, s."""
    gyro_range_rad_s: float = float(deg2rad(300.0))
    accel_range_m_s2: float = float(g2mps2(10.0))
    gap_factor: float = 1.5
    rate_tolerance: float = 0.1
    clear_s: float = 10.0
    """An effect on a channel is reported again only after this long without it."""
    history_s: float = 120.0
    mc_windows: int = 8000
    seed: int = 0


@dataclass
class Trace:
    """Per-window statistics for the plot (lists of (6,) arrays)."""

    t: list = field(default_factory=list)
    level: list = field(default_factory=list)
    line: list = field(default_factory=list)
    noise_cusum: list = field(default_factory=list)
    bias_cusum: list = field(default_factory=list)
