"""Accuracy on the project simulator's paper drive (imu_sim): filtered error below GPS, outages, consistency."""


from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

pytest.importorskip("imu_sim")
from nav_eval import paper_sim as evaluate  # noqa: E402

SCENARIO = Path(__file__).resolve().parents[1] / "config" / "scenarios" / "paper_drive.yaml"


@pytest.fixture(scope="module")
def figures(tmp_path_factory):
    if not SCENARIO.exists():
        pytest.skip(f"scenario not found: {SCENARIO}")
    return evaluate.paper_sim(tmp_path_factory.mktemp("paper_sim"), seed=1, scenario=SCENARIO)["cases"]


@pytest.mark.slow
def test_filtered_position_error_is_below_the_raw_gps_error(figures):
    err = figures["nominal"]["errors"]
    assert err["pos_h_rms_m"] < err["gps_h_rms_m"]
    assert err["yaw_rms_deg"] < 5.0 and err["roll_rms_deg"] < 1.0 and err["pitch_rms_deg"] < 1.0


@pytest.mark.slow
def test_gps_nis_is_near_its_degrees_of_freedom(figures):
    cons = figures["nominal"]["consistency"]
    assert 2.0 < cons["nis_mean"] < 4.0  # 3 dof; the 95 % band for ~700 fixes is about 2.8-3.2
    assert cons["nees_pos_mean"] < 3 * 3.0  # at most a factor 3 overconfident (unmodelled scale factors)


@pytest.mark.slow
def test_longer_outages_drift_further(figures):
    d30 = figures["outage_30s_every_180s"]["outage_drift"]
    d60 = figures["outage_60s_every_180s"]["outage_drift"]
    assert d30["windows"] >= 3 and d60["windows"] >= 3
    assert d60["drift_mean_m"] > d30["drift_mean_m"] > figures["nominal"]["errors"]["pos_h_rms_m"]
