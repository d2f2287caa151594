"""allan_node: characterise IMU noise (Allan deviation + five-term fit) from a recording or a live topic.

Two modes, same core (:mod:`imu_calib.characterise`):

* ``recording`` set: read that rosbag2 bag or recording CSV (``topic`` inside
  a bag), characterise it, write ``out_dir``.
* ``recording`` empty: subscribe to ``topic`` (sensor-data QoS, best effort)
  for ``duration_s`` seconds of message stamps - the stationary head of a run -
  then characterise what arrived and write ``out_dir``.

Writes ``out_dir/sensor_model.yaml``, ``out_dir/imu.yaml`` (Kalibr keys) and
``out_dir/allan.png``; publishes a ``/diagnostics`` status while collecting and
the result (OK with the white noise per axis, or ERROR with the reason) when done.
"""
from __future__ import annotations

import numpy as np
import rclpy
from rclpy.node import Node
from sensor_msgs.msg import Imu

from imu_calib.allan import AllanError
from imu_calib.characterise import characterise, write_outputs
from nav_core.recording import IMU_TOPIC, ImuRecording, RecordingError, read_imu
from nav_core.params import ConfigError, Param
from nav_core.ros_node import (SENSOR_QOS_IN, Diagnostics, declare_parameters,
                               imu_to_arrays, run_node)

PARAMS = (
    Param("recording", "", "rosbag2 bag or recording CSV to characterise; empty = subscribe to topic live"),
    Param("topic", IMU_TOPIC, "IMU topic (live subscription, or inside the bag)"),
    Param("duration_s", 60.0, "live mode: seconds of data (message stamps) to collect", 0.1, 1e6),
    Param("out_dir", "", "output folder for sensor_model.yaml, imu.yaml, allan.png (required)"),
    Param("per_decade", 0, "cluster times per decade; 0 = octave grid", 0, 100),
    Param("exit_when_done", False, "shut the node down after publishing the result"),
    Param("diagnostics_period_s", 1.0, "period of the /diagnostics status, s", 0.05, 60.0),
)


class AllanNode(Node):
    """Collects (or reads) IMU samples, then runs the characterisation once."""

    def __init__(self):
        super().__init__("allan_node")
        self.values = declare_parameters(self, PARAMS)
        if not self.values["out_dir"]:
            raise ConfigError("parameter 'out_dir' is empty: give the folder for sensor_model.yaml, imu.yaml, allan.png")
        self.diag = Diagnostics(self, "allan characterisation")
        self.samples: list = []
        self.final = None
        self.ticks_after_done = 0
        self.sub = None
        if self.values["recording"]:
            self.create_timer(0.1, self._run_offline_once)
        else:
            self.sub = self.create_subscription(Imu, self.values["topic"], self._on_imu, SENSOR_QOS_IN)
            self.get_logger().info(f"collecting {self.values['duration_s']} s of {self.values['topic']}")
        self.create_timer(self.values["diagnostics_period_s"], self._on_diag_timer)

    def _on_imu(self, msg: Imu) -> None:
        if self.final is not None:
            return
        self.samples.append(imu_to_arrays(msg))
        if self.samples[-1][0] - self.samples[0][0] >= self.values["duration_s"]:
            self.destroy_subscription(self.sub)
            self.sub = None
            t = np.array([s[0] for s in self.samples])
            rec = ImuRecording(t, np.array([s[1] for s in self.samples]), np.array([s[2] for s in self.samples]),
                               source=f"live {self.values['topic']} ({len(t)} samples)")
            self._characterise(rec)

    def _run_offline_once(self) -> None:
        if self.final is not None:
            return
        try:
            rec = read_imu(self.values["recording"], topic=self.values["topic"])
        except RecordingError as err:
            self._finish("ERROR", str(err), {})
            return
        self._characterise(rec)

    def _characterise(self, rec: ImuRecording) -> None:
        try:
            result = characterise(rec, per_decade=self.values["per_decade"] or None)
            paths = write_outputs(result, self.values["out_dir"], rostopic="/" + self.values["topic"].lstrip("/"))
        except (AllanError, ValueError) as err:
            self._finish("ERROR", str(err), {"samples": len(rec)})
            return
        values = {"samples": len(rec), "duration_s": float(len(rec) / result.model.sample_rate_hz),
                  **{f"{k}_path": str(v) for k, v in paths.items()}}
        for triad in ("gyro", "accel"):
            for i, n in enumerate(result.model.triad(triad).white_noise):
                values[f"{triad}_{'xyz'[i]}_white_noise"] = float(n)
        self._finish("OK", f"wrote {paths['sensor_model']}", values)

    def _finish(self, level: str, message: str, values: dict) -> None:
        self.final = (level, message, values)
        log = self.get_logger().info if level == "OK" else self.get_logger().error
        log(f"allan_node: {message}")
        self.diag.publish(level, message, values)

    def _on_diag_timer(self) -> None:
        if self.final is None:
            collected = (self.samples[-1][0] - self.samples[0][0]) if len(self.samples) > 1 else 0.0
            self.diag.publish("OK", "collecting", {"samples": len(self.samples), "collected_s": collected})
            return
        self.diag.publish(*self.final)
        self.ticks_after_done += 1
        if self.values["exit_when_done"] and self.ticks_after_done >= 3:
            rclpy.try_shutdown()


def main(args=None) -> int:
    """Console-script entry point (``allan_node``)."""
    return run_node(AllanNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
