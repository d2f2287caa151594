"""imu_sim error model: the Allan deviation of a simulated static run (computed by imu_calib.allan)
matches the model it was simulated from, term by term and for BP3010-grade coefficients."""
import numpy as np
import pytest

from imu_calib.allan import overlapping_adev
from imu_calib.synthetic import terms_of, true_avar
from nav_core.sensor_model import SensorModel, TriadModel

from imu_sim import scenario as scenario_mod
from imu_sim.models import bp3010_grade_model
from imu_sim.simulate import simulate

RATE_HZ = 64.0


def _static(duration_s):
    return scenario_mod.from_dict({"latitude_deg": 45.0, "longitude_deg": 10.0, "height_m": 100.0,
                                   "static_segments": [{"t0": 0, "t1": duration_s, "roll_deg": 0,
                                                        "pitch_deg": 0, "yaw_deg": 0}], "gps": False})


def _model(**terms):
    tri = {k: np.full(3, v) for k, v in terms.items()}
    return SensorModel(gyro=TriadModel(**tri), accel=TriadModel(**{k: v * 10 for k, v in tri.items()
                                                                   if k != "bias_correlation_time"}
                                                                | ({"bias_correlation_time": tri["bias_correlation_time"]}
                                                                   if "bias_correlation_time" in tri else {})))


def _ratio(res, model, max_tau_fraction=0.05):
    """Simulated / model Allan deviation at octave cluster times from 4 samples up to a fraction of the run.

    (At one sample the interval-mean laws of the model do not apply to point-sampled
    random walks; at long cluster times the estimate has few degrees of freedom.)
    """
    out = []
    for name, data in (("gyro", res.imu.gyro), ("accel", res.imu.accel)):
        adev = overlapping_adev(data - data.mean(axis=0), RATE_HZ)
        keep = (adev.taus >= 4 / RATE_HZ) & (adev.taus <= max_tau_fraction * len(data) / RATE_HZ)
        for axis in range(3):
            expected = np.sqrt(true_avar(adev.taus[keep], terms_of(model, name, axis)))
            out.append(adev.adev[keep, axis] / expected)
    return np.array(out)


@pytest.mark.parametrize("terms", [
    {"white_noise": 2e-3},
    {"quantization": 2.5e-6 / np.sqrt(12), "white_noise": 5e-6},  # quantization needs noise to dither it
    {"bias_instability": 2e-4},
    {"bias_instability": 2e-4, "bias_correlation_time": 30.0},
    {"rate_random_walk": 2e-5},
    {"rate_ramp": 1e-6},
], ids=["white", "quantization", "flicker", "gauss_markov", "rate_random_walk", "rate_ramp"])
def test_each_noise_term_alone_gives_its_allan_signature(terms):
    model = _model(**terms)
    res = simulate(_static(1800.0), model, seed=11, rate_hz=RATE_HZ, with_bytes=False)
    ratio = _ratio(res, model)
    assert np.all((ratio > 0.7) & (ratio < 1.3)), np.round(ratio, 2)


@pytest.mark.slow
def test_bp3010_grade_static_hour_allan_deviation_matches_its_model():
    model = bp3010_grade_model()
    res = simulate(_static(3600.0), model, seed=5, rate_hz=RATE_HZ, with_bytes=False)
    ratio = _ratio(res, model)
    assert np.all((ratio > 0.75) & (ratio < 1.25)), np.round(ratio, 2)
    assert np.median(np.abs(ratio - 1)) < 0.1
