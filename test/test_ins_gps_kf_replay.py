"""The offline CLI: ins-gps-kf replay over CSVs and bags; output format; bad input."""


import numpy as np  # noqa: E402
import pytest  # noqa: E402

from nav_core import recording  # noqa: E402
from nav_core import sensor_model as sm  # noqa: E402
from ins_gps_kf import error_model as em  # noqa: E402
from ins_gps_kf import synthetic as syn  # noqa: E402
from ins_gps_kf.replay import main  # noqa: E402

RATE = 32.0


@pytest.fixture
def drive_files(tmp_path):
    motion = syn.circle(still_s=20.0, accel_s=5.0, straight_s=10.0, turn_s=25.0)
    rng = np.random.default_rng(7)
    imu = syn.add_imu_errors(syn.ideal_imu(motion, RATE), rng, 1e-4, 0.01, 1e-3, 1e-3)
    gnss = syn.gnss(motion, RATE, 1.0, rng)
    paths = {"imu": recording.write_imu_csv(tmp_path / "imu.csv", imu),
             "gnss": recording.write_gnss_csv(tmp_path / "gnss.csv", gnss),
             "model": sm.save(em.default_mems_model(), tmp_path / "model.yaml"),
             "bag": recording.write_bag(tmp_path / "drive_bag", imu, gnss, imu_topic="imu/data_corrected")}
    return paths, imu, gnss


def test_replay_of_csvs_writes_the_trajectory_csv_and_plot(drive_files, tmp_path, capsys):
    paths, imu, _ = drive_files
    out = tmp_path / "traj.csv"
    code = main(["replay", "--recording", str(paths["imu"]), "--gnss", str(paths["gnss"]), "--model",
                 str(paths["model"]), "--out", str(out), "--quiet", "--param", "alignment_time_s=15.0"])
    assert code == 0, capsys.readouterr()
    traj = recording.read_trajectory_csv(out)
    assert traj.velocity_n is not None
    for column in ("e_m", "n_m", "u_m", "std_e", "std_n", "std_u", "std_ve", "std_yaw_deg", "nis"):
        assert column in traj.extra
    assert len(traj) == pytest.approx((imu.t[-1] - 15.0) * 2, abs=3)
    assert np.all(np.diff(traj.t) > 0)
    assert out.with_suffix(".png").stat().st_size > 1000


def test_replay_of_a_bag_equals_replay_of_the_csvs(drive_files, tmp_path):
    paths, _, _ = drive_files
    common = ["--model", str(paths["model"]), "--quiet", "--no-plot", "--param", "alignment_time_s=15.0"]
    assert main(["replay", "--recording", str(paths["bag"]), "--out", str(tmp_path / "a.csv"), *common]) == 0
    assert main(["replay", "--recording", str(paths["imu"]), "--gnss", str(paths["gnss"]),
                 "--out", str(tmp_path / "b.csv"), *common]) == 0
    a, b = recording.read_trajectory_csv(tmp_path / "a.csv"), recording.read_trajectory_csv(tmp_path / "b.csv")
    np.testing.assert_allclose(a.t, b.t, atol=1e-6)
    np.testing.assert_allclose(a.extra["e_m"], b.extra["e_m"], atol=1e-3)


def test_replay_with_a_missing_model_exits_2_naming_the_file(drive_files, tmp_path, capsys):
    paths, _, _ = drive_files
    code = main(["replay", "--recording", str(paths["imu"]), "--gnss", str(paths["gnss"]), "--model",
                 str(tmp_path / "nope.yaml"), "--out", str(tmp_path / "t.csv"), "--quiet"])
    assert code == 2
    assert "nope.yaml" in capsys.readouterr().err


def test_replay_with_a_bad_parameter_exits_2(drive_files, tmp_path, capsys):
    paths, _, _ = drive_files
    code = main(["replay", "--recording", str(paths["imu"]), "--gnss", str(paths["gnss"]), "--model", "default",
                 "--out", str(tmp_path / "t.csv"), "--quiet", "--param", "filter_rate_hz=0.0"])
    assert code == 2
    assert "filter_rate_hz" in capsys.readouterr().err
