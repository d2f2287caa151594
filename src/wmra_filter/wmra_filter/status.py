"""The WMRA node's status, typed (:class:`nav_core.status.NodeStatus`): the window in use, samples in and out,
restarts, processing time. The node writes it to ``/diagnostics``; the report reads it through this type."""
from __future__ import annotations

from dataclasses import dataclass

from nav_core.status import NodeStatus


@dataclass
class WmraStatus(NodeStatus):
    """Delay (samples, s), window and thresholds in use, counts since start, processing time per message (us)."""

    SUMMARY = ("restarts", "nonfinite_samples")

    level: str = "STALE"
    message: str = ""
    delay_samples: int = 0
    delay_s: float = 0.0
    window: int = 0
    hop: int = 0
    wavelet_level: int = 0
    wavelet: str = ""
    threshold_mode: str = ""
    threshold_rule: str = ""
    noise_source: str = ""
    thresholds_gyro_rad_s: str = "pending"
    thresholds_accel_m_s2: str = "pending"
    received: int = 0
    published: int = 0
    restarts: int = 0
    filled_samples: int = 0
    nonfinite_samples: int = 0
    last_restart: str = ""
    processing_mean_us: float = 0.0
    intake_period_s: float = 0.0
    bad_messages: int = 0
    processing_max_us: float = 0.0

    def summary(self) -> str:
        """Restarts, and non-finite samples when there were any (why the node WARNs)."""
        return f"restarts {self.restarts}" + (f", nonfinite_samples {self.nonfinite_samples}"
                                              if self.nonfinite_samples else "")
