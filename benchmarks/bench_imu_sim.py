"""Benchmark imu_sim: simulate 1 hour at 64 Hz of road driving with every error term and effect on.

Prints wall time and peak traced memory (targets: < 10 s, < 500 MB), and the peer
measured in the same run: imu_calib.synthetic.static_recording (noise-only, no
trajectory or Earth model) for the same length. ``--quick`` runs 5 minutes.
"""
import argparse
import time
import tracemalloc

import numpy as np

from imu_sim import scenario as scenario_mod
from imu_sim.models import bp3010_grade_model
from imu_sim.simulate import simulate

ALL_PHYSICS = {
    "earth_rotation": {}, "coriolis": {}, "gravity_model": {},
    "gyro_g_sensitivity": {"gyro_coeff_rad_per_s_per_mps2": [1e-4, 1e-4, 1e-4]},
    "temperature_bias": {"gyro_coeff_rad_per_s_per_degc": [1e-5] * 3, "accel_coeff_mps2_per_degc": [1e-3] * 3,
                         "gyro_scale_per_degc": [1e-4] * 3, "accel_scale_per_degc": [1e-4] * 3,
                         "reference_temp_c": 25.0},
    "warmup_drift": {"gyro_amplitude_rad_per_s": [1e-3] * 3, "accel_amplitude_mps2": [0.01] * 3,
                     "time_constant_s": 300.0},
    "vibration": {"sinusoids": [{"frequency_hz": 25.0, "accel_amplitude_mps2": [0.05, 0.05, 0.15],
                                 "gyro_amplitude_rad_per_s": [0.002] * 3}],
                  "random_accel_density_mps2_per_sqrt_hz": [0.005] * 3, "band_hz": [5.0, 32.0]},
    "coning_sculling": {"coning_amplitude_rad": 1e-4, "frequency_hz": 20.0, "sculling_accel_mps2": 0.1},
    "gps_lever_arm": {"lever_arm_m": [0.5, 0.0, 1.2]}, "gps_latency": {"latency_s": 0.1},
    "colored_gps_noise": {"sigma_m": [1.0, 1.0, 2.0], "correlation_time_s": 60.0},
}


def _scenario(duration_s: float):
    leg = [{"type": "accelerate", "duration_s": 10, "speed_mps": 12}, {"type": "cruise", "duration_s": 60},
           {"type": "turn", "duration_s": 10, "angle_deg": 90}, {"type": "cruise", "duration_s": 40},
           {"type": "stop", "duration_s": 10}, {"type": "stand", "duration_s": 20}]
    n_legs = int(np.ceil(duration_s / 150.0))
    return scenario_mod.from_dict({"name": "bench", "latitude_deg": 30.5, "longitude_deg": 114.4, "height_m": 20,
                                   "segments": leg * n_legs, "duration_s": duration_s,
                                   "temperature": {"start_c": 20, "end_c": 40, "time_constant_s": 900},
                                   "gps": {"rate_hz": 1, "outages": [[600, 660]]}})


def _measure(fn):
    """Result, wall time (s, untraced run) and peak traced memory (MB, a second, traced run)."""
    start = time.perf_counter()
    out = fn()
    elapsed = time.perf_counter() - start
    tracemalloc.start()
    fn()
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return out, elapsed, peak / 1e6


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="5 minutes instead of 1 hour")
    args = parser.parse_args()
    duration = 300.0 if args.quick else 3600.0
    scen = _scenario(duration)
    model = bp3010_grade_model(ALL_PHYSICS)
    res, elapsed, peak = _measure(lambda: simulate(scen, model, seed=1))
    n = len(res.imu)
    print(f"imu_sim.simulate: {duration / 60:.0f} min at 64 Hz ({n} samples, all error terms and effects, "
          f"GPS, BP3010 bytes): {elapsed:.2f} s, peak traced memory {peak:.0f} MB "
          f"(targets < 10 s, < 500 MB for 1 h)")
    from imu_calib.synthetic import static_recording
    _, peer_s, peer_mb = _measure(lambda: static_recording(bp3010_grade_model(), duration, np.random.default_rng(1)))
    print(f"peer imu_calib.synthetic.static_recording (noise only, same length): {peer_s:.2f} s, "
          f"peak {peer_mb:.0f} MB")


if __name__ == "__main__":
    main()
