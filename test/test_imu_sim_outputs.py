"""imu_sim outputs: CLI and API write the bag, CSVs, truth and BP3010 stream; same seed, same bytes."""
import subprocess
import sys

import numpy as np
import pytest
import yaml
from hypothesis import given, settings, strategies as st
from hypothesis.extra.numpy import arrays

from nav_core import bagio, recording
from nav_core.processes import executable

from imu_sim import errors
from imu_sim.models import bp3010_grade_model
from imu_sim.simulate import BAG_EPOCH_S, simulate, write_outputs
from nav_core import sensor_model


def _scenario(tmp_path, duration_s=20.0, **extra):
    data = {"name": "short", "latitude_deg": 30.0, "longitude_deg": 114.0, "height_m": 20.0,
            "segments": [{"type": "stand", "duration_s": 5}, {"type": "accelerate", "duration_s": 5, "speed_mps": 5},
                         {"type": "turn", "duration_s": 5, "angle_deg": 45}, {"type": "stop", "duration_s": 5}],
            "duration_s": duration_s, "temperature": {"start_c": 20, "end_c": 30, "time_constant_s": 60},
            "gps": {"rate_hz": 1, "sigma_m": 0.3, "outages": [[8, 12]]}, **extra}
    path = tmp_path / "scenario.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _model(tmp_path):
    model = bp3010_grade_model({"earth_rotation": {}, "coriolis": {}, "gravity_model": {},
                                "temperature_bias": {"gyro_coeff_rad_per_s_per_degc": [1e-5, 1e-5, 2e-5],
                                                     "accel_coeff_mps2_per_degc": [1e-3, 1e-3, 2e-3],
                                                     "reference_temp_c": 25}})
    return sensor_model.save(model, tmp_path / "model.yaml")


def test_same_scenario_and_seed_give_the_same_bytes(tmp_path):
    scen, model = _scenario(tmp_path), _model(tmp_path)
    outs = []
    for name, seed in (("a", 7), ("b", 7), ("c", 8)):
        res = simulate(scen, model, seed=seed)
        write_outputs(res, tmp_path / name, fmt="csv")
        outs.append(tmp_path / name)
    for fname in ("imu.csv", "gnss.csv", "truth.csv", "bp3010.bin"):
        assert (outs[0] / fname).read_bytes() == (outs[1] / fname).read_bytes(), fname
    assert (outs[0] / "imu.csv").read_bytes() != (outs[2] / "imu.csv").read_bytes()
    assert (outs[0] / "truth.csv").read_bytes() == (outs[2] / "truth.csv").read_bytes()


def test_cli_writes_bag_csvs_truth_and_bp3010_stream_readable_by_the_project_readers(tmp_path):
    scen, model = _scenario(tmp_path), _model(tmp_path)
    out = tmp_path / "out"
    proc = subprocess.run([executable("imu-sim"), "simulate", "--scenario", str(scen), "--model", str(model),
                           "--out", str(out), "--seed", "3", "--storage", "mcap"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    imu_csv = recording.read_imu(out / "imu.csv")
    imu_bag = recording.read_imu(out / "bag")
    assert len(imu_csv) == 20 * 64 and imu_csv.t[0] == pytest.approx(1 / 64)
    np.testing.assert_allclose(imu_bag.t - BAG_EPOCH_S, imu_csv.t, atol=1e-6)
    np.testing.assert_allclose(imu_bag.gyro, imu_csv.gyro, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(imu_bag.temp_c, imu_csv.temp_c, atol=1e-6)
    gnss = recording.read_gnss(out / "bag")
    assert np.all(gnss.status[(gnss.t - BAG_EPOCH_S >= 8) & (gnss.t - BAG_EPOCH_S < 12)] == -1)
    from rosbags.interfaces import QosReliability
    qos = bagio.offered_qos(out / "bag")  # was empty: every bag says its QoS, as bag_record's do
    assert set(qos) == {"imu/data_raw", "imu/temperature", "gps/fix"}
    assert all(len(q) == 1 and q[0].reliability == QosReliability.BEST_EFFORT for q in qos.values()), qos
    truth = recording.read_trajectory_csv(out / "truth.csv")
    assert truth.t[0] == 0.0 and len(truth) == len(imu_csv) + 1
    assert (out / "bp3010.bin").stat().st_size == 16 * len(imu_csv)
    assert (out / "overview.png").stat().st_size > 10_000


def test_bp3010_stream_decodes_to_the_simulated_increments_within_one_lsb(tmp_path):
    codec = pytest.importorskip("imu_driver.bp3010_codec")
    res = simulate(_scenario(tmp_path), _model(tmp_path), seed=1)
    rows = np.frombuffer(res.bp3010, dtype=np.uint8).reshape(-1, 16)
    assert codec.checksum_ok(rows).all()
    batch = codec.decode_rows(rows)
    fmt = codec.FrameFormat()
    # The remainder is carried: cumulative angle and velocity stay within half an LSB of the simulation.
    assert np.abs(np.cumsum(batch.dtheta, 0) - np.cumsum(res.dtheta, 0)).max() <= 0.5 * fmt.dtheta_lsb_rad + 1e-12
    assert np.abs(np.cumsum(batch.dv, 0) - np.cumsum(res.dv, 0)).max() <= 0.5 * fmt.dv_lsb_mps + 1e-12


@settings(max_examples=40, deadline=None)
@given(arrays(float, (200, 3), elements=st.floats(-1e-3, 1e-3)), st.floats(1e-7, 1e-4))
def test_quantization_carries_the_remainder_so_the_cumulative_error_stays_below_half_an_lsb(inc, lsb):
    out = errors.quantize_carry(inc, np.full(3, lsb))
    assert np.allclose(np.round(out / lsb), out / lsb, atol=1e-6)
    assert np.abs(np.cumsum(out, 0) - np.cumsum(inc, 0)).max() <= 0.5 * lsb * (1 + 1e-9) + 1e-15


def test_switching_one_noise_term_off_leaves_the_other_terms_realisation_unchanged(tmp_path):
    model = bp3010_grade_model()
    scen = _scenario(tmp_path)
    all_terms = simulate(scen, model, seed=4, with_bytes=False)
    no_flicker = simulate(scen, model, seed=4, terms=[t for t in errors.TERMS if t != "bias_instability"],
                          with_bytes=False)
    only_flicker = simulate(scen, model, seed=4, terms=["bias_instability"], with_bytes=False)
    ideal = simulate(scen, model, seed=4, terms=[], with_bytes=False)
    # With quantization off in the pieces, the parts add up (the matrix terms act on the truth only).
    lin = [t for t in errors.TERMS if t != "quantization"]
    a = simulate(scen, model, seed=4, terms=lin, with_bytes=False).imu.gyro
    b = simulate(scen, model, seed=4, terms=[t for t in lin if t != "bias_instability"], with_bytes=False).imu.gyro
    np.testing.assert_allclose(a - b, only_flicker.imu.gyro - ideal.imu.gyro, atol=1e-12)
    assert not np.allclose(all_terms.imu.gyro, no_flicker.imu.gyro)


def test_cli_reports_a_bad_scenario_field_and_exits_nonzero(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump({"latitude_deg": 30, "longitude_deg": 1, "static_segments": [{"t0": 0}]}))
    proc = subprocess.run([sys.executable, "-m", "imu_sim.cli", "simulate", "--scenario", str(bad),
                           "--out", str(tmp_path / "o")], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert "bad.yaml" in proc.stderr and "static_segments[0]" in proc.stderr
