"""Compile every numba kernel of the workspace into its on-disk cache (``cache=True``: __pycache__ beside the source).

Run by ``scripts/setup_env.sh`` after the install, so a new user's first command (``ins-gps-kf replay``, the
node, ``imu-calib allan``, ``sensor_health_node``) loads compiled kernels instead of compiling them: a minute on a
busy 2-core machine for the filter alone (41 s against 8.6 s for a 15-minute drive's first and second replay).
Each package's kernels are run once on small inputs with the types real input has.
"""
from __future__ import annotations

import time

import numpy as np


def warm_filter() -> None:
    """ins_gps_kf: strapdown, covariance and update kernels (15 and 21 states) through the filter's warm-up."""
    from ins_gps_kf import config
    from ins_gps_kf.intake import warm_up

    for scale_factors in (False, True):
        p = config.defaults()
        p["estimate_scale_factors"] = scale_factors
        warm_up(config.from_params(p))


def warm_calibration() -> None:
    """imu_calib: Allan variance, its covariance (the fit's intervals) and the multi-position gyro rotation."""
    from imu_calib import gyro_multi_position
    from imu_calib.characterise import characterise
    from nav_core.recording import ImuRecording

    rng = np.random.default_rng(0)
    n = 64 * 600
    rec = ImuRecording(np.arange(n) / 64.0, rng.normal(0.0, 1e-3, (n, 3)),
                       rng.normal(0.0, 1e-2, (n, 3)) + [0.0, 0.0, 9.8])
    characterise(rec)
    gyro_multi_position._rotate_back(np.zeros((4, 3)), 1.0 / 64.0, np.ones(3))


def warm_diagnosis() -> None:
    """imu_sim diagnose: the local-level (random walk / Gauss-Markov) likelihood filter."""
    from imu_sim.diagnose import local_level

    local_level.loglik(np.random.default_rng(0).normal(size=200), local_level.ratio_grid(), 0.1, 0.5)


def warm_health() -> None:
    """sensor_health: the bias CUSUMs' counted false alarms and their split tail, run as the node's start-up runs
    them (a monitor of the shipped BP3010-grade model)."""
    from imu_sim.models import bp3010_grade_model
    from sensor_health.monitor import HealthMonitor

    HealthMonitor(bp3010_grade_model(), keep_trace=False)


WARMERS = (("ins_gps_kf", warm_filter), ("imu_calib", warm_calibration), ("imu_sim", warm_diagnosis),
           ("sensor_health", warm_health))
"""(package, its warmer): every package whose source compiles a numba kernel (test/test_workspace_numba_warm.py)."""


def main() -> int:
    """Warm each package's kernels; print what took how long."""
    for name, warm in WARMERS:
        t0 = time.monotonic()
        warm()
        print(f"setup: numba kernels of {name} compiled and cached ({time.monotonic() - t0:.1f} s)", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
