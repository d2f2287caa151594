"""The wheel odometer in the node (issue 25): bag_play plays a bag with a TwistStamped odom/wheel topic (sensor-data
QoS) to ins_gps_kf_node, which learns the type from the graph; its odometry equals the offline replay of the same
bag with the odometer and NHC on, and /diagnostics counts the same bad wheel speeds and NHC rejections."""
import time

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from rclpy.qos import QoSProfile  # noqa: E402

from nav_core import recording  # noqa: E402
from nav_core.processes import NodeProcess  # noqa: E402
from nav_core.ros_node import Probe  # noqa: E402
from ins_gps_kf import config  # noqa: E402
from ins_gps_kf.filter import InsGpsFilter  # noqa: E402
from ins_gps_kf.offline import run  # noqa: E402
from ins_gps_kf.replay import replay_files  # noqa: E402
from ins_gps_kf.status import FilterStatus  # noqa: E402

pytestmark = pytest.mark.ros
PARAMS = {"alignment_time_s": 15.0, "imu_rate_hz": 32.0, "odometer_enabled": True, "nhc_enabled": True}


def _stamp(msg) -> float:
    return msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec


def _filter_up_to(t_end, imu, gnss, wheel):
    """The offline filter after the recordings' input up to ``t_end`` s."""
    filt = InsGpsFilter(config.from_params(PARAMS))
    keep = wheel.t <= t_end
    run(filt, imu.select(imu.t <= t_end), gnss.select(gnss.t <= t_end), odometry=(wheel.t[keep], wheel.speed_mps[keep]))
    return filt


def test_node_on_a_bag_with_a_wheel_odometer_equals_the_replay_and_counts_its_bad_input(
        wheel_drive, rclpy_context, tmp_path):
    imu, gnss, wheel = wheel_drive
    late = gnss.t >= 2.0  # no fix in the first 2 s: a lead-in that DDS may lose without changing the answer
    bag = recording.write_bag(tmp_path / "bag", imu, gnss.select(late), imu_topic="imu/data_corrected",
                              wheel=wheel, wheel_type="geometry_msgs/msg/TwistStamped")
    traj, _ = replay_files(bag, None, "default", tmp_path / "replay.csv", PARAMS, plot=False, progress=False)
    odom = Probe({"odometry/filtered": Odometry}, name="odom_probe", qos=QoSProfile(depth=1000))
    diag = Probe({"/diagnostics": DiagnosticArray}, name="diag_probe")
    node = NodeProcess("ins_gps_kf_node", env=rclpy_context, ros_args=PARAMS)
    player = None
    try:
        assert node.wait_for_line("ready", 30.0), node.output
        player = NodeProcess("bag_play", env=rclpy_context, ros_args={
            "bag": str(bag), "rate": 6.0, "publish_clock": False, "wait_for_subscribers": 1, "settle_s": 1.0})
        last = traj.t[traj.t < imu.t[-1] - 0.2][-1]  # the newest 0.1 s wait in the node's window: no epoch there
        deadline = time.monotonic() + 60.0
        while time.monotonic() < deadline and not any(abs(_stamp(m) - last) < 1e-6
                                                      for _, m in odom.received["odometry/filtered"]):
            rclpy.spin_once(odom, timeout_sec=0.05)
            rclpy.spin_once(diag, timeout_sec=0.0)
        diag.spin_until(lambda p: False, 1.5)  # the status after the last epoch
    finally:
        codes = (player.stop() if player else None, node.stop())
    assert "wheel odometer: odom/wheel as geometry_msgs/msg/TwistStamped" in node.output, node.output
    live = {round(_stamp(m), 6): m for _, m in odom.received["odometry/filtered"]}
    assert len(live) >= len(traj) - 2, (len(live), len(traj), node.output, player.output)
    for i, t in enumerate(traj.t):
        if round(t, 6) in live:
            p = live[round(t, 6)].pose.pose.position
            np.testing.assert_allclose([p.x, p.y, p.z], [traj.extra[k][i] for k in ("e_m", "n_m", "u_m")], atol=1e-6)
    values = [{kv.key: kv.value for kv in s.values} for _, a in diag.received["/diagnostics"] for s in a.status
              if s.name.startswith("ins_gps_kf")]
    st = FilterStatus.from_values(values[-1])
    filt = _filter_up_to(last + 0.4, imu, gnss.select(late), wheel)  # what the node had processed at its last epoch
    c = filt.counters
    assert (st.odometer_updates, st.odometer_rejected, st.nhc_updates, st.nhc_rejected) == (
        c.odometer_updates, c.odometer_rejected, c.nhc_updates, c.nhc_rejected)
    assert st.odometer_updates > 40 and st.nhc_updates > 40
    odometer_input = {k: v for k, v in filt.input_counters.items() if k.startswith("odometer")}
    assert {k: getattr(st.input, k) for k in odometer_input} == odometer_input
    assert odometer_input["odometer_nonfinite"] == 1 and odometer_input["odometer_out_of_order"] == 1
    assert (st.wheel_speeds_received, st.late_odometer, st.bad_odometer_messages) == (len(wheel), 0, 0)
    assert st.odometer_scale_pct == pytest.approx(100.0 * filt.odometer.scale, abs=1e-4)
    assert codes[1] == 0, node.output
    odom.destroy_node()
    diag.destroy_node()
