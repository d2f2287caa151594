"""ins-gps-kf evaluate --trajectory (issue 25): the forward and smoothed trajectories of replay --smooth against a
truth through a GNSS outage: the largest error per outage, 3-sigma bands, the plot."""
import json

from conftest import wheel_motion
from ins_gps_kf import synthetic as syn
from ins_gps_kf.replay import main
from nav_core import recording
from nav_eval.cli import main as nav_eval_main


def test_evaluate_scores_forward_and_smoothed_through_an_outage_found_in_the_forward_run(wheel_drive, tmp_path,
                                                                                        capsys):
    imu, gnss, _ = wheel_drive
    cut = gnss.select((gnss.t < 35.0) | (gnss.t >= 50.0))  # a 15-s outage while driving round the bend
    imu_csv = recording.write_imu_csv(tmp_path / "imu.csv", imu)
    gnss_csv = recording.write_gnss_csv(tmp_path / "gnss.csv", cut)
    truth_csv = recording.write_trajectory_csv(tmp_path / "truth.csv", syn.truth_trajectory(wheel_motion(), 32.0))
    out = tmp_path / "smoothed.csv"
    assert main(["replay", "--recording", str(imu_csv), "--gnss", str(gnss_csv), "--model", "default", "--smooth",
                 "--quiet", "--no-plot", "--param", "imu_rate_hz=32.0", "--param", "alignment_time_s=15.0",
                 "--out", str(out)]) == 0
    capsys.readouterr()
    assert main(["evaluate", "--trajectory", str(out), "--truth", str(truth_csv), "--out", str(tmp_path / "eval")]) == 0
    figures = json.loads(capsys.readouterr().out)
    assert figures == json.loads((tmp_path / "eval" / "outages.json").read_text())
    # nav-eval, the command the issue names, is the same command
    assert nav_eval_main(["--trajectory", str(out), "--truth", str(truth_csv), "--out", str(tmp_path / "ne")]) == 0
    assert json.loads(capsys.readouterr().out) == figures
    assert (tmp_path / "eval" / "outages.png").stat().st_size > 10000
    (t0, t1), = figures["outages"]
    assert 33.9 <= t0 <= 35.0 and 50.0 <= t1 <= 50.1  # from the last update before to the first after
    fwd, smo = figures["forward_largest_per_outage_m"][0], figures["smoothed_largest_per_outage_m"][0]
    assert fwd > 1.0 and smo < 0.5 * fwd, figures
    assert figures["smoothed_no_worse_fraction"] > 0.8
    assert figures["forward_inside_3sigma_fraction"] > 0.9
    assert 0.0 < figures["smoothed_inside_3sigma_fraction"] <= 1.0  # 0.86: at rest before the heading is known the
    # smoothed std (0.45 m) is below the error (1.4 m) on this drive - the smoother's, reported, not this tool's
    # the errors a user makes, named
    assert main(["evaluate", "--trajectory", str(out), "--truth", str(truth_csv), "--outage", "50:35",
                 "--out", str(tmp_path / "given")]) == 2
    assert "--outage '50:35': T1 must be after T0" in capsys.readouterr().err
    assert main(["evaluate", "--trajectory", str(out), "--out", str(tmp_path / "x")]) == 2
    assert "--trajectory needs --truth" in capsys.readouterr().err
    assert main(["evaluate", "--trajectory", str(imu_csv), "--truth", str(truth_csv), "--out", str(tmp_path / "y")]) == 2
    assert "imu.forward.csv: not found" in capsys.readouterr().err
    assert figures["smoothed_largest_rms_m"] == smo  # one outage: its largest error


def test_the_outage_study_cuts_outages_and_the_demo_report_says_each_largest_error(wheel_drive):
    from ins_gps_kf import config
    from ins_gps_kf.error_model import default_mems_model
    from nav_bringup.offline_runs import outage_lines
    from nav_eval.outages import outage_study

    imu, gnss, wheel = wheel_drive
    truth = syn.truth_trajectory(wheel_motion(), 32.0)
    params = {**config.defaults(), "imu_rate_hz": 32.0, "alignment_time_s": 15.0}
    figures, fwd, smo, windows = outage_study(imu, gnss, truth, params, default_mems_model(), period_s=20.0,
                                              length_s=10.0)
    assert windows == [(20.0, 30.0), (40.0, 50.0)]
    assert len(fwd.t) == len(smo.t) > 60
    f, s = figures["forward_largest_per_outage_m"], figures["smoothed_largest_per_outage_m"]
    assert f[1] > 1.0 and s[1] < 0.5 * f[1], figures  # the outage while driving; the first is at rest (ZUPT)
    lines = outage_lines(figures)
    assert f"forward {figures['forward_largest_rms_m']:.2f} m, smoothed {figures['smoothed_largest_rms_m']:.2f} m" \
        in lines[0] and f"{f[1]:.1f} / {s[1]:.1f}" in lines[1]
    assert "not run (why)" in outage_lines({"not run": "why"})[0]
