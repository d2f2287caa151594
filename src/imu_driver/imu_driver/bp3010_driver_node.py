"""``bp3010_driver``: read BP3010 frames from a serial port and publish ``sensor_msgs/Imu`` on ``imu/data_raw``.

A background thread reads the port (pyserial) and publishes; the executor
thread runs the diagnostics timer. The node never exits on bad bytes or a
lost port: it reports and reconnects every ``reconnect_period_s``. Parameters
changed at runtime are applied (``port``, ``baud`` and ``rate_hz`` reopen the
port and send the rate command) or refused (the frame layout and the stamping).
"""
from __future__ import annotations

import math
import struct
import threading
import time

import numpy as np
import serial
from rcl_interfaces.msg import SetParametersResult
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu

from imu_driver.bp3010_codec import ACCEL_WHITE_NOISE, FIELDS, GYRO_WHITE_NOISE, RATE_SELECT, FrameFormat
from imu_driver.driver_core import ClockFollower, DriverCore, SimTimeStamper
from imu_driver.status import driver_status
from nav_core import sensor_model, units
from nav_core.imu_cdr import stamps_from_s
from nav_core.params import ConfigError, Param
from nav_core.ros_node import (Diagnostics, PolledSubscription, declare_parameters, link_publisher, publish_imu_batch,
                               run_node)
from rclpy.node import Node

# The BP3010's white noise (bp3010_codec) at 64 Hz: sigma per sample = N sqrt(rate).
GYRO_SIGMA_64HZ = GYRO_WHITE_NOISE * math.sqrt(64.0)
ACCEL_SIGMA_64HZ = ACCEL_WHITE_NOISE * math.sqrt(64.0)

PARAMS = (
    Param("port", "/dev/ttyUSB0", "serial device (or a stable symlink such as /dev/serial/by-id/...)"),
    Param("baud", 38400, "UART speed, bit/s (8N1)", 1200, 4_000_000),
    Param("rate_hz", 64, "output rate, Hz; selected on start with 7B 88/89/8A/8B", choices=(64, 32, 16, 8)),
    Param("frame_id", "imu_link", "frame_id of the published messages"),
    Param("angular_velocity_stddev", GYRO_SIGMA_64HZ, "1-sigma angular rate noise per sample, rad/s (covariance "
          "diagonal; default: the BP3010 model at 64 Hz)", 0.0, 10.0),
    Param("linear_acceleration_stddev", ACCEL_SIGMA_64HZ, "1-sigma specific force noise per sample, m/s^2 "
          "(default: the BP3010 model at 64 Hz)", 0.0, 100.0),
    Param("sensor_model_path", "", "sensor-model YAML; when set, the two stddevs are its white noise x "
          "sqrt(rate_hz) (largest axis) instead"),
    Param("reconnect_period_s", 1.0, "time between attempts to reopen a lost port, s", 0.01, 600.0),
    Param("diagnostics_period_s", 1.0, "period of /diagnostics, s", 0.05, 60.0),
    Param("min_read_interval_s", 0.002, "the reader waits at least this long between reads, s: at 1 kHz a read "
          "per frame costs more than the frame (adds at most this much latency; 0 = read every frame)", 0.0, 0.1),
    Param("max_clock_drift_ppm", 200.0, "largest rate difference between the unit's and the host's clock, ppm: "
          "the fitted drift is clipped to it (0 under use_sim_time: a simulated unit runs on the simulated clock)",
          0.0, 10000.0),
    Param("stamp_window_s", 10.0, "stamps follow the smallest read delay seen over this much time, s", 0.1, 3600.0),
    Param("stamp_slew", 0.5, "when stamps are ahead of the counter model, each frame advances at least "
          "(1 - stamp_slew) periods until they meet it (never a step back)", 0.01, 0.99),
    Param("stamp_settle_s", 0.5, "after start-up and each re-anchor, the frames of this much time are held, then "
          "stamped one period apart on the most prompt read among them, s (0 = stamp each read at once)", 0.0, 10.0),
    Param("frame.sync", 0xA5, "sync byte value", 0, 255),
    Param("frame.checksum", "sum_zero", "checksum kind", choices=("sum_zero", "sum", "xor")),
    Param("frame.byteorder", "little", "byte order of the int16 increments", choices=("little", "big")),
    Param("frame.field_order", list(FIELDS), "order of the six increments in the frame"),
    Param("frame.dtheta_lsb_rad", 2.5e-6, "angle increment scale, rad/LSB", 1e-12, 1.0),
    Param("frame.dv_lsb_mps", 5e-5, "velocity increment scale, (m/s)/LSB", 1e-12, 10.0),
)


APPLIED_AT_RUNTIME = ("port", "baud", "rate_hz", "frame_id", "angular_velocity_stddev", "linear_acceleration_stddev",
                      "reconnect_period_s", "min_read_interval_s", "diagnostics_period_s")
"""Parameters a running driver applies; the others are read-only (``set_parameters`` refuses them)."""
_CLOCK_CDR = struct.Struct("<iI")  # builtin_interfaces/Time after the 4-byte CDR header


class Bp3010Driver(Node):
    """The serial driver node."""

    def __init__(self, **kwargs):
        super().__init__("bp3010_driver", **kwargs)
        self.p = declare_parameters(self, PARAMS, dynamic=APPLIED_AT_RUNTIME)  # the others are read-only
        try:
            fmt = FrameFormat(sync=self.p["frame.sync"], checksum=self.p["frame.checksum"],
                              byteorder=self.p["frame.byteorder"], field_order=tuple(self.p["frame.field_order"]),
                              dtheta_lsb_rad=self.p["frame.dtheta_lsb_rad"], dv_lsb_mps=self.p["frame.dv_lsb_mps"])
        except ValueError as err:
            raise ConfigError(f"frame layout: {err}") from err
        self._noise_density = self._load_noise_density()
        sim_time = self.get_parameter("use_sim_time").value
        # Under simulated time the unit is simulated on the clock's own time base: no drift to estimate.
        max_drift = 0.0 if sim_time else self.p["max_clock_drift_ppm"] * 1e-6
        self.core = DriverCore(self.p["rate_hz"], fmt, max_drift=max_drift, window_s=self.p["stamp_window_s"],
                               slew=self.p["stamp_slew"], settle_s=self.p["stamp_settle_s"])
        self.pub = link_publisher(self, Imu, "imu/data_raw")
        self.diag = Diagnostics(self, "BP3010", hardware_id=self.p["port"])
        self.port_state = "connecting"
        self.reconnects = 0
        self.last_error = ""
        self._serial = None
        self._reopen = threading.Event()
        self._frames_at_last_diag = 0
        self._last_diag_time = time.monotonic()
        self._stop = threading.Event()
        self._set_noise()
        # Under simulated time the node's clock stands still between /clock deliveries: read /clock's receive times.
        self._sim = self._stamper = None
        if sim_time:
            self._sim = ClockFollower()
            self._stamper = SimTimeStamper(self.core, self._sim)  # holds reads until their simulated time is known
            self._clock_sub = PolledSubscription(self, Clock, "/clock", None, None)
        self.add_on_set_parameters_callback(self._refuse_fixed)
        self.add_post_set_parameters_callback(self._apply)
        self._thread = threading.Thread(target=self._read_loop, name="bp3010_reader", daemon=True)
        self._thread.start()
        self._diag_timer = self.create_timer(self.p["diagnostics_period_s"], self._publish_diagnostics)
        self.get_logger().info(f"ready: port {self.p['port']} at {self.p['baud']} baud, {self.p['rate_hz']} Hz")

    # -- parameters ------------------------------------------------------

    def _load_noise_density(self):
        """White noise (gyro rad/s/sqrt(Hz), accel m/s^2/sqrt(Hz)) of ``sensor_model_path``, largest axis; or None."""
        path = self.p["sensor_model_path"]
        if not path:
            return None
        try:
            model = sensor_model.load(path)
        except (OSError, ValueError) as err:
            raise ConfigError(f"parameter 'sensor_model_path': {err}") from None
        return float(np.max(model.gyro.white_noise)), float(np.max(model.accel.white_noise))

    def _set_noise(self) -> None:
        if self._noise_density is not None:
            root = np.sqrt(self.p["rate_hz"])
            self.p["angular_velocity_stddev"] = self._noise_density[0] * root
            self.p["linear_acceleration_stddev"] = self._noise_density[1] * root
        self._gyro_var = self.p["angular_velocity_stddev"] ** 2
        self._accel_var = self.p["linear_acceleration_stddev"] ** 2

    def _refuse_fixed(self, changes) -> SetParametersResult:
        fixed = [c.name for c in changes if c.name.endswith("_stddev")] if self._noise_density is not None else []
        if fixed:
            return SetParametersResult(successful=False, reason=f"{', '.join(fixed)}: set from sensor_model_path "
                                       f"{self.p['sensor_model_path']!r}")
        return SetParametersResult(successful=True)

    def _apply(self, changes) -> None:
        names = {c.name for c in changes}
        for change in changes:
            if change.name in self.p:
                self.p[change.name] = change.value
        self._set_noise()
        if "diagnostics_period_s" in names:
            self.destroy_timer(self._diag_timer)
            self._diag_timer = self.create_timer(self.p["diagnostics_period_s"], self._publish_diagnostics)
        if names & {"port", "baud", "rate_hz"}:
            self.diag.hardware_id = self.p["port"]
            self._reopen.set()  # the reader closes the port and opens it with the new settings
        self.get_logger().info("applied " + ", ".join(f"{c.name}={c.value!r}" for c in changes))

    # -- port ------------------------------------------------------------

    def _open(self) -> bool:
        try:
            self._serial = serial.Serial(self.p["port"], self.p["baud"], timeout=0.1)
            self._serial.write(RATE_SELECT[self.p["rate_hz"]])
        except (serial.SerialException, OSError) as err:
            self._serial = None
            self._set_state("waiting for port", str(err))
            return False
        if self.port_state != "connecting":
            self.reconnects += 1
        self.core.set_rate(self.p["rate_hz"])
        self._set_state("connected", "")
        return True

    def _set_state(self, state: str, error: str) -> None:
        if state != self.port_state:
            text = f"port {self.p['port']}: {state}" + (f" ({error})" if error else "")
            # rclpy forbids one call site logging at two severities, hence two calls.
            if state == "connected":
                self.get_logger().info(text)
            else:
                self.get_logger().warning(text)
        self.port_state, self.last_error = state, error or self.last_error

    def _read_loop(self) -> None:
        while not self._stop.is_set():
            try:
                self._read_once()
            except Exception as err:  # the reader must outlive any surprise; report and go on
                self.last_error = f"{type(err).__name__}: {err}"
                self.get_logger().error(f"reader: {self.last_error}")
                self._stop.wait(self.p["reconnect_period_s"])

    def _read_once(self) -> None:
        """Open the port if needed, read what is there, publish the frames."""
        if self._reopen.is_set():
            self._reopen.clear()
            self._close_port()
            self.port_state = "reopening"
        if self._serial is None and not self._open():
            self._stop.wait(self.p["reconnect_period_s"])
            return
        try:
            # a whole frame per blocking read (or what is waiting): a read per byte costs more than the frame
            data = self._serial.read(max(self.core.decoder.fmt.length, self._serial.in_waiting))
        except (serial.SerialException, OSError, TypeError) as err:
            self._close_port()
            self._set_state("disconnected", str(err))
            self._stop.wait(self.p["reconnect_period_s"])
            return
        read_at, wall = time.monotonic(), time.time()
        if data or self.core.holding:  # a silent port still ends the stamps' settling after start-up
            self._publish(data, wall)
        wait = read_at + self.p["min_read_interval_s"] - time.monotonic()
        if wait > 0 and data:
            self._stop.wait(wait)

    def _publish(self, data: bytes, wall_s: float) -> None:
        """Decode a read made at ``wall_s`` (system time, s), stamp and publish its frames."""
        if self._sim is None:
            self._send(self.core.feed(data, self.get_clock().now().nanoseconds * 1e-9))
            return
        for blob, received_ns in self._clock_sub.take_all():
            sec, nanosec = _CLOCK_CDR.unpack_from(blob, 4)
            self._sim.update(units.s_from_sec_nanosec(sec, nanosec), received_ns * 1e-9)
        for samples in self._stamper.stamp(self.core.decoder.feed(data), wall_s):
            self._send(samples)

    def _send(self, samples) -> None:
        if len(samples.t):
            # raw CDR for the whole read: building rclpy Imu objects cost ~70 us a frame, 7 % of a core at 1 kHz
            sec, nanosec = stamps_from_s(samples.t)
            publish_imu_batch(self.pub, sec, nanosec, samples.gyro, samples.accel, self.p["frame_id"],
                              gyro_var=self._gyro_var, accel_var=self._accel_var)

    def _close_port(self) -> None:
        if self._serial is not None:
            try:
                self._serial.close()
            except (serial.SerialException, OSError):
                pass
        self._serial = None

    # -- diagnostics -----------------------------------------------------

    def _publish_diagnostics(self) -> None:
        stats, clock = self.core.decoder.stats, self.core.clock
        now = time.monotonic()
        rate = (stats.frames - self._frames_at_last_diag) / max(now - self._last_diag_time, 1e-9)
        self._frames_at_last_diag, self._last_diag_time = stats.frames, now
        st = driver_status(stats, clock, rate, self.p["rate_hz"], self.p["port"], self.port_state, self.reconnects,
                           self._sim.rate if self._sim else 0.0,
                           self._stamper.frames_before_clock if self._stamper else 0, self.last_error)
        self.diag.publish(st.level, st.message, st.to_values())

    def close(self) -> None:
        """Stop the reader thread and close the port."""
        self._stop.set()
        self._thread.join(timeout=2.0)
        self._close_port()


def main(args=None) -> int:
    """Entry point of ``bp3010_driver``."""
    return run_node(Bp3010Driver, args, usage=(
        "bp3010_driver",
        "Read BP3010 frames from a serial port and publish sensor_msgs/Imu on imu/data_raw.",
        PARAMS,
        "bp3010_driver --ros-args --params-file config/navigation.yaml -p port:=/dev/ttyUSB0"))


if __name__ == "__main__":
    raise SystemExit(main())
