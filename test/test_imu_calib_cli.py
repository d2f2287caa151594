"""imu-calib CLI: allan writes sensor_model.yaml, imu.yaml, allan.png from a CSV or a bag; calibration subcommands."""
import subprocess

import numpy as np
import pytest
import yaml

from conftest import shared_data
from imu_calib import synthetic
from imu_calib.cli import main
from nav_core import sensor_model
from nav_core.processes import executable
from nav_core.recording import write_bag, write_imu_csv

TRUTH = sensor_model.SensorModel(
    gyro=sensor_model.TriadModel(white_noise=np.full(3, 8.7e-4), bias_instability=np.full(3, 3e-4)),
    accel=sensor_model.TriadModel(white_noise=np.full(3, 1.2e-3)), sample_rate_hz=20.0)


def _recording(duration_s, seed=0):
    return synthetic.static_recording(TRUTH, duration_s, np.random.default_rng(seed))


def test_allan_cli_writes_model_kalibr_yaml_and_plot_from_a_csv(tmp_path):
    csv = write_imu_csv(tmp_path / "static.csv", _recording(1800.0))
    out = tmp_path / "out"
    proc = subprocess.run([executable("imu-calib"), "allan", str(csv), "--out", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    model = sensor_model.load(out / "sensor_model.yaml")
    np.testing.assert_allclose(model.gyro.white_noise, 8.7e-4, rtol=0.05)
    np.testing.assert_allclose(model.accel.white_noise, 1.2e-3, rtol=0.05)
    assert model.gyro.intervals["white_noise"].shape == (3, 2)
    assert model.provenance["tool"] == "imu_calib allan" and model.sample_rate_hz == pytest.approx(20.0)
    kalibr = yaml.safe_load((out / "imu.yaml").read_text())
    assert set(kalibr) >= {"gyroscope_noise_density", "gyroscope_random_walk", "accelerometer_noise_density",
                           "accelerometer_random_walk", "update_rate"}
    assert kalibr["gyroscope_noise_density"] == pytest.approx(np.max(model.gyro.white_noise))
    assert (out / "allan.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_allan_cli_reads_a_rosbag2_bag_on_the_given_topic(tmp_path):
    bag = write_bag(tmp_path / "bag", imu=_recording(120.0, 1), imu_topic="/imu/raw_test")
    out = tmp_path / "out"
    assert main(["allan", str(bag), "--out", str(out), "--topic", "imu/raw_test", "--per-decade", "8",
                 "--no-progress"]) == 0
    assert yaml.safe_load((out / "imu.yaml").read_text())["rostopic"] == "/imu/raw_test"
    model = sensor_model.load(out / "sensor_model.yaml")
    np.testing.assert_allclose(model.gyro.white_noise, 8.7e-4, rtol=0.15)


def test_allan_cli_says_the_recording_is_too_short_instead_of_writing_nan(tmp_path, capsys):
    csv = write_imu_csv(tmp_path / "short.csv", _recording(1.0))
    assert main(["allan", str(csv), "--out", str(tmp_path / "out"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "recording too short" in err and "20 samples" in err
    assert not (tmp_path / "out" / "sensor_model.yaml").exists()


def test_two_position_cli_updates_the_model_with_real_ucalgary_data(tmp_path, capsys):
    model_path = tmp_path / "model.yaml"
    d = "ucalgary_adi_updown"
    assert main(["two-position", "--up", str(shared_data(d, "x_adi_up.txt")), "--down",
                 str(shared_data(d, "x_adi_down.txt")), "--format", "ucalgary", "--axis", "x",
                 "--lat-deg", "51.0784", "--height-m", "1100", "--out", str(model_path)]) == 0
    model = sensor_model.load(model_path)
    assert abs(model.accel.bias[0]) < 0.05 and model.accel.bias[1] == 0.0
    assert "local gravity 9.808" in capsys.readouterr().out


def test_rate_table_cli_writes_gyro_scale_and_bias(tmp_path):
    rng = np.random.default_rng(2)
    recs = []
    for k, rate_dps in enumerate((50.0, -50.0)):
        rec = _recording(60.0, 10 + k)
        rec.gyro[:, 2] = (1 - 0.007) * (np.deg2rad(rate_dps) + 7.292115e-5 * np.sin(np.deg2rad(45.0))) \
            + np.deg2rad(0.3172) + rng.normal(0, 1e-4, len(rec))
        recs.append(write_imu_csv(tmp_path / f"r{k}.csv", rec))
    out = tmp_path / "m.yaml"
    assert main(["rate-table", "--rec1", str(recs[0]), "--rate1-dps", "50", "--rec2", str(recs[1]),
                 "--rate2-dps", "-50", "--axis", "z", "--lat-deg", "45", "--out", str(out)]) == 0
    model = sensor_model.load(out)
    assert model.gyro.scale_factor[2] == pytest.approx(-0.007, abs=2e-4)
    assert np.rad2deg(model.gyro.bias[2]) == pytest.approx(0.3172, abs=2e-3)


def test_multi_position_cli_on_imutk_raw_counts(tmp_path, capsys):
    out = tmp_path / "mp.yaml"
    d = "imutk_multiposition"
    assert main(["multi-position", str(shared_data(d, "xsens_acc.mat")), "--gyro-file",
                 str(shared_data(d, "xsens_gyro.mat")), "--format", "imutk", "--gravity", "9.81",
                 "--out", str(out)]) == 0
    assert "static segments" in capsys.readouterr().out
    assert sensor_model.load(out).accel.info["multi_position"]["static_segments"] >= 30


def test_cli_names_a_missing_recording(tmp_path, capsys):
    assert main(["allan", str(tmp_path / "nope.csv"), "--out", str(tmp_path)]) == 2
    assert "nope.csv: recording not found" in capsys.readouterr().err
