"""Small helpers around nav_core.sensor_model for the calibration tools: load-or-new, per-axis intervals."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from nav_core import sensor_model


def load_or_new(path, sample_rate_hz: float | None = None) -> sensor_model.SensorModel:
    """The sensor model at ``path`` if it exists (validated), else a new empty one."""
    path = Path(path)
    model = sensor_model.load(path) if path.exists() else sensor_model.SensorModel()
    if sample_rate_hz is not None:
        model.sample_rate_hz = float(sample_rate_hz)
    return model


def set_interval(triad, term: str, axis: int, interval) -> None:
    """Set the 95 % interval of one axis of ``term``; other axes keep theirs (or a point interval)."""
    value = np.asarray(getattr(triad, term), dtype=float)
    current = triad.intervals.get(term)
    current = np.stack([value, value], axis=-1) if current is None else np.array(current, dtype=float)
    current[axis] = interval
    triad.intervals[term] = current
