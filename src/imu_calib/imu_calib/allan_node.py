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

The characterisation (reading a recording, the Allan fit, the plot) runs in a
separate process niced by ``worker_nice``, so on a small machine it takes only
the CPU the driver, the denoiser and the filter leave, and this node keeps
spinning: its diagnostics say ``characterising`` with the worker's pid meanwhile.
"""
from __future__ import annotations

import multiprocessing
import os

import numpy as np
import rclpy
from rclpy.node import Node
from sensor_msgs.msg import Imu

from imu_calib import characterise
from imu_calib.status import AllanStatus
from nav_core.recording import IMU_TOPIC, ImuRecording
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
    Param("worker_nice", 10, "niceness added to the characterisation process (0 = same priority)", 0, 19),
    Param("split_at_gaps", True, "analyse the longest unbroken segment when stamps go back, repeat with other "
                                 "values or have a gap, or a sample is NaN/inf (what was skipped is in the YAML); "
                                 "false = report an ERROR"),
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
        self.proc = None
        self.conn = None
        self.n_collected = 0
        self.n_non_finite = 0  # live samples with a NaN or infinite value: kept, the worker's time line breaks there
        if self.values["recording"]:
            self._start_worker(self.values["recording"])
        else:
            self.sub = self.create_subscription(Imu, self.values["topic"], self._on_imu, SENSOR_QOS_IN)
            self.get_logger().info(f"collecting {self.values['duration_s']} s of {self.values['topic']}")
        self.create_timer(self.values["diagnostics_period_s"], self._on_diag_timer)

    def _on_imu(self, msg: Imu) -> None:
        if self.final is not None or self.proc is not None:
            return
        self.samples.append(imu_to_arrays(msg))
        if not (np.all(np.isfinite(self.samples[-1][1])) and np.all(np.isfinite(self.samples[-1][2]))):
            self.n_non_finite += 1
        if self.samples[-1][0] - self.samples[0][0] >= self.values["duration_s"]:
            self.destroy_subscription(self.sub)
            self.sub = None
            t = np.array([s[0] for s in self.samples])
            rec = ImuRecording(t, np.array([s[1] for s in self.samples]), np.array([s[2] for s in self.samples]),
                               source=f"live {self.values['topic']} ({len(t)} samples)")
            self._characterise(rec)

    def _characterise(self, rec: ImuRecording) -> None:
        self.n_collected = len(rec)
        self._start_worker(rec)

    def _start_worker(self, source) -> None:
        """Run the characterisation in a niced child process (spawned: no copy of this node's threads)."""
        ctx = multiprocessing.get_context("spawn")
        self.conn, child = ctx.Pipe(duplex=False)
        v = self.values
        go = ctx.Event()
        self.proc = ctx.Process(target=characterise.worker, name="allan_worker", daemon=True,
                                args=(child, go, source, v["out_dir"], v["topic"], v["per_decade"] or None,
                                      v["split_at_gaps"]))
        self.proc.start()
        child.close()
        # lower the child's priority from here before it does anything (its imports included), then let it go
        os.setpriority(os.PRIO_PROCESS, self.proc.pid, os.getpriority(os.PRIO_PROCESS, 0) + v["worker_nice"])
        go.set()
        self._go = go  # the child unpickles it later: the semaphore must outlive this call
        self.get_logger().info(f"characterising in process {self.proc.pid} (nice +{v['worker_nice']})")

    def _poll_worker(self) -> None:
        """Take the worker's result once it is there (or its death without one)."""
        if self.conn is None:
            return
        if self.conn.poll():
            try:
                level, payload = self.conn.recv()
            except EOFError:
                level, payload = "ERROR", "the characterisation process ended without a result"
        elif not self.proc.is_alive():
            level, payload = "ERROR", f"the characterisation process died (exit code {self.proc.exitcode})"
        else:
            return
        self.conn.close()
        self.conn = None
        self.proc.join(timeout=5.0)
        if level == "OK":
            self._finish(AllanStatus.of("OK", f"wrote {payload['sensor_model_path']}", payload))
        else:
            self._finish(AllanStatus("ERROR", payload, samples=self.n_collected, non_finite_samples=self.n_non_finite))

    def close(self) -> None:
        """Stop a running worker (shutdown before the result)."""
        if self.proc is not None and self.proc.is_alive():
            self.proc.terminate()
            self.proc.join(timeout=5.0)

    def _finish(self, status: AllanStatus) -> None:
        self.final = status
        log = self.get_logger().info if status.level == "OK" else self.get_logger().error
        log(f"allan_node: {status.message}")
        self._publish(status)

    def _publish(self, status: AllanStatus) -> None:
        self.diag.publish(status.level, status.message, status.to_values())

    def _on_diag_timer(self) -> None:
        self._poll_worker()
        if self.final is None and self.proc is not None:
            self._publish(AllanStatus("OK", "characterising", samples=self.n_collected, worker_pid=self.proc.pid,
                                      worker_nice=self.values["worker_nice"]))
            return
        if self.final is None:
            collected = (self.samples[-1][0] - self.samples[0][0]) if len(self.samples) > 1 else 0.0
            self._publish(AllanStatus("OK", "collecting", samples=len(self.samples), collected_s=float(collected),
                                      non_finite_samples=self.n_non_finite))
            return
        self._publish(self.final)
        self.ticks_after_done += 1
        if self.values["exit_when_done"] and self.ticks_after_done >= 3:
            rclpy.try_shutdown()


def main(args=None) -> int:
    """Console-script entry point (``allan_node``)."""
    return run_node(AllanNode, args, usage=(
        "allan_node",
        "Characterise IMU noise (Allan deviation, five-term fit) from a recording or a live topic.",
        PARAMS,
        "allan_node --ros-args -p recording:=static_bag -p out_dir:=out/allan -p exit_when_done:=true"))


if __name__ == "__main__":
    raise SystemExit(main())
