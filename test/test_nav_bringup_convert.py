"""nav-convert turns the public recordings into replayable bags with truth, a sensor model and params."""
import numpy as np
import pytest
import yaml

from conftest import shared_data
from nav_bringup.convert import EPOCH_S, main
from nav_core import recording, sensor_model


@pytest.mark.slow
def test_katwijk_becomes_a_bag_with_reference_truth_model_and_params(tmp_path):
    shared_data("navego_rover", "katwijk_imu_planetary.mat")
    assert main(["katwijk", "--out", str(tmp_path)]) == 0
    imu, gnss = recording.read_imu(tmp_path / "bag"), recording.read_gnss(tmp_path / "bag")
    assert imu.damage is None and abs(imu.rate_hz - 125.0) < 0.5 and len(gnss) > 90
    assert imu.t[0] >= EPOCH_S and np.median(imu.accel[:1000, 2]) > 9.0  # body z up at rest
    truth = recording.read_trajectory_csv(tmp_path / "truth.csv")
    assert truth.t[0] >= EPOCH_S and len(truth) > 1000
    model = sensor_model.load(tmp_path / "sensor_model.yaml")
    assert model.sample_rate_hz == pytest.approx(imu.rate_hz, rel=1e-3)
    assert np.all(model.gyro.white_noise > 0) and np.all(model.accel.white_noise > 0)
    params = yaml.safe_load((tmp_path / "navigation.yaml").read_text())
    assert params["ins_gps_kf_node"]["ros__parameters"]["imu_rate_hz"] == pytest.approx(imu.rate_hz, rel=1e-3)
    assert params["wmra_node"]["ros__parameters"]["sample_rate_hz"] == pytest.approx(imu.rate_hz, rel=1e-3)


@pytest.mark.slow
def test_balzer_car_becomes_a_bag_in_body_flu_with_its_gps(tmp_path):
    csv = shared_data("balzer_car", "2014-02-14-002-Data.csv")
    assert main(["balzer", "--csv", str(csv), "--out", str(tmp_path)]) == 0
    imu, gnss = recording.read_imu(tmp_path / "bag"), recording.read_gnss(tmp_path / "bag")
    assert np.median(imu.accel[:, 2]) > 9.0, "the logger's z-down axes must arrive as REP-103 z up"
    assert 5.0 < 1.0 / np.median(np.diff(gnss.t)) < 15.0 and np.all(gnss.std_enu > 0)
    assert not (tmp_path / "truth.csv").exists()


def test_unknown_source_is_refused(tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(["nowhere", "--out", str(tmp_path)])
