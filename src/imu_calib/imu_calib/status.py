"""The Allan node's status, typed (:class:`nav_core.status.NodeStatus`): collecting, characterising, then the
result (paths, white noise per axis) or the error. The node writes it to ``/diagnostics``; readers parse it back
through this type."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from nav_core.status import NodeStatus


@dataclass
class AllanStatus(NodeStatus):
    """Samples so far (and s collected), the worker process, then :func:`imu_calib.characterise.characterise_to_dir`'s
    summary: duration (s), dropped samples, output paths, white noise (rad/s/sqrt(Hz), m/s^2/sqrt(Hz)), warnings."""

    SUMMARY = ("samples",)

    level: str = "STALE"
    message: str = ""
    samples: int = 0
    collected_s: float = 0.0
    non_finite_samples: int = 0
    worker_pid: int = 0
    worker_nice: int = 0
    duration_s: float = 0.0
    skipped_samples: int = 0
    exact_duplicates_dropped: int = 0
    sensor_model_path: str = ""
    kalibr_path: str = ""
    plot_path: str = ""
    gyro_x_white_noise: float = 0.0
    gyro_y_white_noise: float = 0.0
    gyro_z_white_noise: float = 0.0
    accel_x_white_noise: float = 0.0
    accel_y_white_noise: float = 0.0
    accel_z_white_noise: float = 0.0
    warnings: str = ""

    @classmethod
    def of(cls, level: str, message: str, values: dict) -> AllanStatus:
        """The status from a summary mapping (the worker's); a key it has no field for is a bug (TypeError)."""
        names = {f.name for f in dataclasses.fields(cls)}
        extra = sorted(set(values) - names)
        if extra:
            raise TypeError(f"AllanStatus has no field for {extra}")
        return cls(level, message, **values)
