"""wmra_node wiring: a real node process fed by an rclpy publisher, observed with a Probe."""
import time

import numpy as np
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import Imu

from nav_core import sensor_model
from nav_core.processes import NodeProcess
from rclpy.qos import QoSProfile, ReliabilityPolicy

from nav_core.ros_node import SENSOR_QOS, Probe, imu_from_arrays, imu_to_arrays, stamp_to_s
from nav_core.sensor_model import SensorModel, TriadModel
from wmra_filter.streaming import StreamingWmra
from wmra_filter.wmra import WmraConfig, calibrate, model_sample_sigma

pytestmark = pytest.mark.ros
FS = 64.0
HOP = 4


def _model(tmp_path):
    model = SensorModel(gyro=TriadModel(bias=np.array([0.01, -0.02, 0.0055]), white_noise=np.full(3, 8.7e-4)),
                        accel=TriadModel(bias=np.array([0.1, 0.0, 0.133]), scale_factor=np.array([0, 0, 0.0041]),
                                         white_noise=np.full(3, 1.2e-3)), sample_rate_hz=FS)
    return model, sensor_model.save(model, tmp_path / "bp3010.yaml")


def _samples(n, t0, seed):
    rng = np.random.default_rng(seed)
    t = t0 + np.arange(n) / FS
    gyro = np.where(t[:, None] % 2 < 1, 0.3, -0.2) * [0, 0, 1] + rng.normal(size=(n, 3)) * 8.7e-4 * 8
    accel = np.array([0, 0, 9.81]) + rng.normal(size=(n, 3)) * 1.2e-3 * 8
    return t, gyro, accel


def _expected(model, segments):
    """The core's streaming output for the same input, restarted between segments.

    Returns stamp -> (6,), the cumulative number of outputs after each input, and the config.
    """
    cfg = WmraConfig.for_bandwidth(FS, hop=HOP)
    stream = StreamingWmra(cfg, 6, sample_sigma=model_sample_sigma(model, FS))
    out, counts = [], []
    for i, (t, gyro, accel) in enumerate(segments):
        for j, sample in enumerate(calibrate(gyro, accel, model)):
            if i and not j:
                out += stream.restart()
            out += stream.push(sample, tag=t[j])
            counts.append(len(out))
    return {round(tag, 6): value for tag, value in out}, counts, cfg


@pytest.fixture
def running(tmp_path, ros_env, rclpy_context):
    """The node as a process with a model, a probe on its outputs and a feeder publisher: (model, node, probe, pub)."""
    model, path = _model(tmp_path)
    node = NodeProcess("wmra_node", env=ros_env, ros_args={"sensor_model_path": str(path), "hop": HOP,
                                                           "diagnostics_period_s": 0.2})
    try:
        assert node.wait_for_line("ready", 30), node.output
        # best effort like SENSOR_QOS, but a deep queue: a gap flushes a whole delay's worth at once
        probe = Probe({"imu/data_corrected": Imu, "/diagnostics": DiagnosticArray},
                      qos=QoSProfile(depth=1000, reliability=ReliabilityPolicy.BEST_EFFORT))
        feeder = rclpy.create_node("feeder")
        pub = feeder.create_publisher(Imu, "imu/data_raw", SENSOR_QOS)
        assert probe.spin_until(lambda p: pub.get_subscription_count() > 0
                                and p.count_publishers("imu/data_corrected") > 0, 20)
        yield model, node, probe, pub
        feeder.destroy_node()
        probe.destroy_node()
    finally:
        node.stop()


def _publish(pub, probe, t, gyro, accel, counts):
    """Publish, pacing by the outputs: best effort drops nothing if the node is never behind."""
    for ti, g, a, count in zip(t, gyro, accel, counts):
        pub.publish(imu_from_arrays(ti, g, a))
        probe.spin_until(lambda p: len(p.received["imu/data_corrected"]) >= count, 10)
        time.sleep(0.003)


def test_node_denoises_preserves_stamps_matches_core_and_restarts_on_gap(running):
    model, node, probe, pub = running
    first, second = _samples(150, 100.0, 1), _samples(100, 110.0, 2)  # 7.7 s gap between them
    expected, counts, cfg = _expected(model, [first, second])
    _publish(pub, probe, *first, counts[:150])
    _publish(pub, probe, *second, counts[150:])
    assert probe.spin_until(lambda p: len(p.received["imu/data_corrected"]) >= len(expected), 20), \
        f"{len(probe.received['imu/data_corrected'])} of {len(expected)} outputs; node said:\n{node.output}"
    assert len(expected) == 150 + 100 - cfg.delay_samples
    got = {round(stamp_to_s(m.header.stamp), 6): m for _, m in probe.received["imu/data_corrected"]}
    assert set(got) == set(expected)
    for stamp, msg in got.items():
        _, gyro, accel = imu_to_arrays(msg)
        np.testing.assert_allclose(np.concatenate([gyro, accel]), expected[stamp], rtol=0, atol=1e-12)
        assert msg.header.frame_id == "imu_link"
        sigma = model_sample_sigma(model, cfg.sample_rate_hz)  # covariances carried, not "unknown" zeros
        np.testing.assert_allclose(np.diag(np.reshape(msg.angular_velocity_covariance, (3, 3))), sigma[:3] ** 2)
        np.testing.assert_allclose(np.diag(np.reshape(msg.linear_acceleration_covariance, (3, 3))), sigma[3:] ** 2)

    def restart_reported(p):
        for _, arr in p.received["/diagnostics"]:
            values = {kv.key: kv.value for st in arr.status if "wmra" in st.name for kv in st.values}
            if values.get("restarts") == "1" and "gap" in values.get("last_restart", ""):
                return values
        return None
    assert probe.spin_until(restart_reported, 10), "no diagnostics reporting the restart"
    diag = restart_reported(probe)
    assert diag["delay_samples"] == str(cfg.delay_samples) and diag["window"] == str(cfg.window_samples)
    assert diag["thresholds_gyro_rad_s"].startswith("L1:") and float(diag["processing_mean_us"]) > 0


def test_node_exits_with_status_2_and_a_message_on_bad_config(tmp_path, ros_env):
    # the wiring: a configuration error in the node is one message and exit 2 (the checks themselves run
    # in-process below)
    node = NodeProcess("wmra_node", env=ros_env, ros_args={"sensor_model_path": "/nonexistent/model.yaml"})
    try:
        assert node.proc.wait(timeout=30) == 2
    finally:
        node.stop()
    assert "/nonexistent/model.yaml: sensor-model file not found" in node.output


@pytest.mark.parametrize("params, message", [({"wavelet": "db99"}, "wavelet 'db99'"), ({"window": 40}, "window 40")])
def test_bad_wavelet_parameters_are_refused_naming_the_value(tmp_path, params, message):
    from wmra_filter.wmra import WmraConfigError
    from wmra_filter.wmra_node import PARAMS, config_from_params, load_model
    model = load_model(str(_model(tmp_path)[1]))
    with pytest.raises(WmraConfigError, match=message):
        config_from_params({**{p.name: p.default for p in PARAMS}, **params}, model)


def test_an_empty_or_missing_sensor_model_path_is_a_config_error_naming_the_parameter(tmp_path):
    from nav_core.params import ConfigError
    from wmra_filter.wmra_node import load_model
    for path in ("", str(tmp_path / "none.yaml")):
        with pytest.raises(ConfigError, match="sensor_model_path"):
            load_model(path)


def test_node_fills_a_dropped_message_instead_of_restarting(running):
    model, node, probe, pub = running
    t, gyro, accel = _samples(200, 100.0, 3)
    drop = 120
    # The core's output for the same input with the dropped sample interpolated (and not published).
    cfg = WmraConfig.for_bandwidth(FS, hop=HOP)
    stream = StreamingWmra(cfg, 6, sample_sigma=model_sample_sigma(model, FS))
    samples = calibrate(gyro, accel, model)
    samples[drop] = 0.5 * (samples[drop - 1] + samples[drop + 1])
    out, counts = [], []
    for j in range(200):
        out += stream.push(samples[j], tag=None if j == drop else t[j])
        if j != drop:
            counts.append(len([o for o in out if o[0] is not None]))
    expected = {round(tag, 6): value for tag, value in out if tag is not None}
    keep = np.arange(200) != drop
    _publish(pub, probe, t[keep], gyro[keep], accel[keep], counts)
    assert probe.spin_until(lambda p: len(p.received["imu/data_corrected"]) >= len(expected), 20)
    got = {round(stamp_to_s(m.header.stamp), 6): m for _, m in probe.received["imu/data_corrected"]}
    assert set(got) == set(expected) and round(t[drop], 6) not in got
    for stamp, msg in got.items():
        _, g, a = imu_to_arrays(msg)
        np.testing.assert_allclose(np.concatenate([g, a]), expected[stamp], rtol=0, atol=1e-12)

    def filled(p):
        for _, arr in reversed(p.received["/diagnostics"]):
            values = {kv.key: kv.value for st in arr.status if "wmra" in st.name for kv in st.values}
            if values.get("filled_samples") == "1":
                return values
        return None
    assert probe.spin_until(filled, 10), "no diagnostics reporting the filled sample"
    assert filled(probe)["restarts"] == "0"
