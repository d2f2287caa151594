"""Filter parameters: one spec shared by the node (ROS parameters) and the offline replay (params YAML).

Degrees, mg and deg/h appear only here, in parameter names; :class:`FilterConfig` holds SI.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from nav_core.params import ConfigError, Param, did_you_mean, read_yaml_file, unknown_keys_error
from nav_core.units import DEG, MG, DEG_PER_H

NODE_NAME = "ins_gps_kf_node"


class FilterConfigError(ValueError):
    """A parameter is invalid; the message names it (the node turns it into ConfigError)."""


PARAMETERS = (
    Param("imu_topic", "imu/data_corrected", "IMU input topic (remap to imu/data_raw for raw data)"),
    Param("gps_topic", "gps/fix", "NavSatFix input topic"),
    Param("odometer_topic", "odom/wheel", "wheel odometer topic (nav_msgs/Odometry or geometry_msgs/TwistStamped: the "
          "forward speed in twist.linear.x), used with odometer_enabled; in a bag, what the replay reads"),
    Param("sensor_model_path", "", "sensor-model YAML (nav_core.sensor_model); empty = hand-tuned MEMS default"),
    Param("apply_sensor_model_calibration", False, "subtract the model's bias/scale/misalignment from the IMU"),
    Param("imu_rate_hz", 64.0, "nominal IMU rate, Hz (stamps give the real dt)", 1.0, 5000.0),
    Param("gps_rate_hz", 1.0, "nominal GPS rate, Hz (GPS age warning at 3 periods)", 0.05, 100.0),
    Param("filter_rate_hz", 2.0, "Kalman filter (covariance propagation and update) rate, Hz", 0.1, 100.0),
    Param("alignment_time_s", 45.0, "stationary time used for coarse alignment, s", 1.0, 600.0),
    Param("min_alignment_time_s", 5.0, "shortest stationary period accepted if motion starts early, s", 0.5, 600.0),
    Param("stationary_gyro_dps", 2.0, "stationarity: rms angular rate below this, deg/s", 0.0, 100.0),
    Param("stationary_accel_mg", 50.0, "stationarity: |f| deviation from its mean below this, mg", 0.0, 1000.0),
    Param("alignment_mode", "stationary", "stationary: level and gyro bias from a detected rest period; in_motion: "
         "level from the mean specific force while the GPS track shows nearly constant velocity, heading and velocity "
         "from the GPS course, gyro bias zero (for vehicles that never stand still)",
         choices=("stationary", "in_motion")),
    Param("motion_alignment_window_s", 10.0, "in_motion: window of IMU samples and GPS fixes judged at once, s",
         0.5, 60.0),
    Param("motion_alignment_max_accel_mps2", 0.2, "in_motion: largest fitted horizontal GPS acceleration (speed "
         "change and centripetal) accepted; the level error is about this / g, m/s^2", 0.0, 10.0),
    Param("motion_alignment_gyro_bias", True, "in_motion: initial x/y gyro bias = mean rate over the window minus "
         "the GPS course rate (a constant-velocity window turns only about the vertical), z zero; false = zero, or "
         "the sensor model's bias when its calibration is not applied"),
    Param("initial_roll_deg", float("nan"), "in_motion: roll from this parameter instead of the specific force, "
         "deg; NaN = measured", -180.0, 180.0),
    Param("initial_pitch_deg", float("nan"), "in_motion: pitch from this parameter instead of the specific force, "
         "deg; NaN = measured", -90.0, 90.0),
    Param("initial_yaw_deg", float("nan"), "initial yaw (ENU, 0 = east, CCW), deg; NaN = from GPS course"),
    Param("heading_min_speed_mps", 0.3, "GPS ground speed needed to take the heading from the course, m/s",
         0.0, 100.0),
    Param("datum_lat_deg", float("nan"), "local ENU datum latitude, deg; NaN = first valid fix", -90.0, 90.0),
    Param("datum_lon_deg", float("nan"), "local ENU datum longitude, deg; NaN = first valid fix", -180.0, 180.0),
    Param("datum_h_m", 0.0, "local ENU datum height, m (used with datum_lat_deg)", -1000.0, 10000.0),
    Param("lever_arm_x_m", 0.0, "GPS antenna position in body x (forward), m", -100.0, 100.0),
    Param("lever_arm_y_m", 0.0, "GPS antenna position in body y (left), m", -100.0, 100.0),
    Param("lever_arm_z_m", 0.0, "GPS antenna position in body z (up), m", -100.0, 100.0),
    Param("gps_std_m", 0.0, "GPS horizontal std, m; 0 = use the NavSatFix covariance", 0.0, 1000.0),
    Param("gps_std_up_m", 0.0, "GPS vertical std, m; 0 = use the NavSatFix covariance", 0.0, 1000.0),
    Param("min_gps_std_m", 0.05, "floor on the GPS std taken from messages, m", 0.0, 100.0),
    Param("gate_probability", 0.9999, "chi-square gate: fixes with NIS above this quantile are rejected", 0.5, 1.0),
    Param("max_rejected_fixes", 5, "this many gated-out fixes in a row reset the position to GPS", 1, 1000),
    Param("reuse_last_fix", False, "paper option: re-use the last GPS fix at intermediate filter epochs"),
    Param("zupt_enabled", True, "zero-velocity updates when the IMU is stationary"),
    Param("zupt_max_gps_speed_mps", 0.1, "no ZUPT while the GPS speed (less 3 sigma of its noise) exceeds this, "
         "m/s", 0.0, 100.0),
    Param("zupt_max_ins_speed_mps", 0.2, "no ZUPT while the INS speed exceeds this, m/s", 0.0, 100.0),
    Param("zupt_max_ins_speed_outage_mps", 0.0, "ZUPT in GNSS outages (a car, 1.0; 0 = off: a slow rover's cruise "
          "looks like rest to the IMU): without a fresh fix the stale GPS speed does not veto and the INS speed limit "
          "rises to 3 sigma of the INS's own horizontal speed, at most this, m/s", 0.0, 100.0),
    Param("zupt_std_mps", 0.02, "zero-velocity measurement std, m/s", 1e-4, 10.0),
    Param("zupt_std_outage_mps", 0.2, "zero-velocity std in a GNSS outage (zupt_max_ins_speed_outage_mps), at least "
          "zupt_std_mps: without a fresh fix rest is the IMU's word alone, and it cannot tell a slow cruise (a rover's "
          "0.2 m/s) from rest, m/s", 0.0, 10.0),
    Param("zupt_gate_probability", 0.99, "chi-square gate of the zero-velocity update: a vehicle pulling away gently, "
          "which the IMU and the GPS chord cannot yet tell from rest, fails it", 0.5, 1.0),
    Param("nhc_enabled", False, "non-holonomic constraints: a land vehicle's lateral and vertical velocity at the "
         "constraint point is zero (a measurement each filter epoch, skipped at rest, gated)"),
    Param("nhc_std_mps", 0.1, "non-holonomic constraint std (lateral and vertical velocity), m/s", 1e-3, 10.0),
    Param("nhc_gate_probability", 0.999, "chi-square gate of the constraint: a skid, a jump or a vehicle it does not "
         "fit fails it (counted as nhc_rejected)", 0.5, 1.0),
    Param("nhc_mounting", "estimate", "estimate: the IMU's pitch and yaw in the vehicle are two filter states "
         "started at mounting_*_deg with mounting_std_deg (NHC observes them against the GNSS-aided velocity); given: "
         "held at mounting_*_deg", choices=("given", "estimate")),
    Param("mounting_std_deg", 5.0, "initial std of the estimated mounting pitch and yaw (nhc_mounting estimate), deg",
         0.0, 90.0),
    Param("mounting_roll_deg", 0.0, "IMU-to-vehicle mounting roll (vehicle = R(mounting) body), deg", -180.0, 180.0),
    Param("mounting_pitch_deg", 0.0, "IMU-to-vehicle mounting pitch, deg", -90.0, 90.0),
    Param("mounting_yaw_deg", 0.0, "IMU-to-vehicle mounting yaw, deg", -180.0, 180.0),
    Param("nhc_lever_arm_x_m", 0.0, "point the constraint holds at (rear axle) in body x (forward) from the IMU, m",
         -100.0, 100.0),
    Param("nhc_lever_arm_y_m", 0.0, "constraint point in body y (left), m", -100.0, 100.0),
    Param("nhc_lever_arm_z_m", 0.0, "constraint point in body z (up), m", -100.0, 100.0),
    Param("odometer_enabled", False, "wheel odometer: forward speed as a measurement with its scale-factor error as "
         "a filter state (replay --odometry sets it)"),
    Param("odometer_std_mps", 0.05, "wheel speed noise std, m/s", 1e-4, 10.0),
    Param("odometer_scale_std_pct", 2.0, "initial std of the odometer's scale-factor error, %", 0.0, 100.0),
    Param("odometer_max_age_s", 0.15, "a wheel speed stamped longer than this before a filter epoch is not used "
          "there (a gap: odometer_gaps; NHC goes on alone), s", 0.0, 10.0),
    Param("odometer_latency_s", 0.0, "the wheel speed was measured this long before its stamp (a fixed latency of "
          "the odometer's message), s; the speed is related to the INS state at stamp - latency", 0.0, 5.0),
    Param("odometer_stuck_speed_mps", 2.0, "a wheel speed of exactly 0 while the INS says faster than this is a "
         "stuck wheel (counted as odometer_stuck, not used), m/s", 0.0, 100.0),
    Param("estimate_scale_factors", False, "21 states: also estimate gyro and accel scale-factor errors"),
    Param("init_scale_factor_std_pct", 1.0, "initial gyro and accel scale-factor std (with estimate_scale_factors), "
         "%", 0.0, 100.0),
    Param("init_gyro_bias_std_dph", 100.0, "initial gyro bias std after alignment, deg/h", 0.0, 1e6),
    Param("init_accel_bias_std_mg", 20.0, "initial accel bias std, mg", 0.0, 1e4),
    Param("init_attitude_std_deg", 1.0, "initial roll/pitch std after alignment, deg", 0.0, 90.0),
    Param("heading_std_deg", 10.0, "initial heading std (course or parameter), deg", 0.0, 180.0),
    Param("flicker_correlation_time_s", 300.0, "Gauss-Markov time for flicker bias instability (one state per "
          "axis), s", 1.0, 1e6),
    Param("bias_gm_states_per_axis", 1, "Gauss-Markov states per flicker bias axis: 1 = one state (sigma B, "
          "flicker_correlation_time_s); n > 1: a sum fitted to the flicker's Allan deviation from 2 s to "
          "bias_gm_band_max_s, n - 1 more states per flicker axis", 1, 5),
    Param("bias_gm_band_max_s", 1000.0, "with bias_gm_states_per_axis > 1: the longest averaging time the sum fits "
          "the flicker's Allan plateau to, s", 10.0, 1e6),
    Param("reorder_window_s", 0.1, "node: messages are held this long and processed in stamp order, s", 0.0, 5.0),
    Param("time_jump_s", 1.0, "backward stamp jump or IMU gap that resets the filter, s", 0.01, 1e6),
    Param("max_bridged_gap_s", 30.0, "a forward IMU gap up to this long (a lost serial port) is bridged by holding "
         "the last sample and growing the covariance, instead of resetting, s; 0 = always reset", 0.0, 3600.0),
    Param("bridge_accel_std_mps2", 1.0, "vehicle acceleration std assumed while bridging an IMU gap, m/s^2",
         0.0, 100.0),
    Param("bridge_rate_std_dps", 5.0, "vehicle turn-rate std assumed while bridging an IMU gap, deg/s", 0.0, 1000.0),
    Param("max_speed_mps", 100.0, "physical limit on the vehicle's speed: a GPS chord or course faster than this "
         "(beyond its noise) is a jump, and an INS faster than twice this has diverged (reset), m/s", 0.1, 1e4),
    Param("max_accel_mps2", 20.0, "physical limit on the vehicle's acceleration: a GPS track turning or speeding "
         "up faster than this (beyond its noise) has jumped, and no GPS reset follows a jump, m/s^2", 0.1, 1e4),
    Param("imu_max_gyro_dps", 2000.0, "IMU samples with a larger |rate| component are impossible (beyond the "
         "sensor's range): rejected and counted, deg/s", 1.0, 1e5),
    Param("imu_max_accel_mps2", 160.0, "IMU samples with a larger |specific force| component are impossible: "
         "rejected and counted, m/s^2", 1.0, 1e5),
    Param("frame_id", "map", "odometry pose frame: local ENU at the datum, GPS-corrected (REP-105 map; it may "
          "jump, the continuous odom frame is the node's odom_frame_id)"),
    Param("child_frame_id", "base_link", "odometry twist / body frame"),
)
SPEC_BY_NAME = {s.name: s for s in PARAMETERS}
NODE_ONLY = frozenset({"use_sim_time", "intake_period_s", "input_queue_depth", "publish_tf", "odom_frame_id",
                       "imu_frame_id", "gps_frame_id", "odometer_msg_type", "qos_overrides"})
"""Parameters of the node's ROS side (declared in ins_gps_kf_node) that the shared params file may hold:
the core and the offline replay skip them."""


@dataclass(frozen=True)
class FilterConfig:
    """The core's settings, SI units (built from parameters by :func:`from_params`)."""

    imu_rate_hz: float = 64.0
    gps_rate_hz: float = 1.0
    filter_rate_hz: float = 2.0
    alignment_time_s: float = 45.0
    min_alignment_time_s: float = 5.0
    stationary_gyro: float = 2.0 * DEG
    stationary_accel: float = 50.0 * MG
    alignment_mode: str = "stationary"
    motion_window_s: float = 10.0
    motion_max_accel: float = 0.2
    motion_gyro_bias: bool = True
    initial_roll: float = math.nan
    initial_pitch: float = math.nan
    initial_yaw: float = math.nan
    heading_min_speed: float = 0.3
    datum: tuple | None = None
    lever_arm_b: tuple = (0.0, 0.0, 0.0)
    gps_std: float = 0.0
    gps_std_up: float = 0.0
    min_gps_std: float = 0.05
    gate_probability: float = 0.9999
    reuse_last_fix: bool = False
    max_rejected_fixes: int = 5
    zupt_enabled: bool = True
    zupt_std: float = 0.02
    zupt_std_outage: float = 0.2  # m/s, in a GNSS outage
    zupt_gate_probability: float = 0.99
    zupt_max_gps_speed: float = 0.1
    zupt_max_ins_speed: float = 0.2
    zupt_max_ins_speed_outage: float = 0.0  # m/s, 0: off
    nhc_enabled: bool = False
    nhc_std: float = 0.1
    nhc_gate_probability: float = 0.999
    mounting_rpy: tuple = (0.0, 0.0, 0.0)  # rad
    nhc_mounting: str = "estimate"
    mounting_std: float = 5.0 * DEG  # rad
    nhc_lever_arm_b: tuple = (0.0, 0.0, 0.0)  # m
    odometer_enabled: bool = False
    odometer_std: float = 0.05
    odometer_scale_std: float = 0.02
    odometer_max_age: float = 0.15  # s
    odometer_latency: float = 0.0  # s
    odometer_stuck_speed: float = 2.0
    estimate_scale_factors: bool = False
    init_scale_factor_std: float = 0.01
    init_gyro_bias_std: float = 100.0 * DEG_PER_H
    init_accel_bias_std: float = 20.0 * MG
    init_attitude_std: float = 1.0 * DEG
    heading_std: float = 10.0 * DEG
    flicker_correlation_time: float = 300.0
    bias_gm_per_axis: int = 1
    bias_gm_band_max: float = 1000.0  # s
    time_jump: float = 1.0
    max_bridged_gap: float = 30.0
    bridge_accel_std: float = 1.0
    bridge_rate_std: float = 5.0 * DEG
    apply_calibration: bool = False
    max_speed: float = 100.0
    max_accel: float = 20.0
    imu_max_gyro: float = 2000.0 * DEG
    imu_max_accel: float = 160.0


def defaults() -> dict:
    """Parameter name -> default value."""
    return {s.name: s.default for s in PARAMETERS}


def check(name: str, value) -> None:
    """Raise FilterConfigError if ``value`` is out of range for parameter ``name``."""
    spec = SPEC_BY_NAME.get(name)
    if spec is None:
        raise FilterConfigError(f"unknown parameter {name!r}{did_you_mean(name, SPEC_BY_NAME)}; "
                                f"known: {sorted(SPEC_BY_NAME)}")
    try:  # one rule for node, params file and CLI: type, range, and NaN only where NaN means unset
        spec.check(value)
    except ConfigError as err:
        raise FilterConfigError(str(err)) from None


def from_params(params: dict) -> FilterConfig:
    """Validate a name -> value mapping (missing names take defaults) and build the SI config."""
    p = defaults()
    p.update(params)
    for name, value in p.items():
        check(name, value)
    if p["min_alignment_time_s"] > p["alignment_time_s"]:
        raise FilterConfigError("parameter 'min_alignment_time_s' must not exceed 'alignment_time_s'")
    has_lat, has_lon = not math.isnan(p["datum_lat_deg"]), not math.isnan(p["datum_lon_deg"])
    if has_lat != has_lon:
        raise FilterConfigError("parameters 'datum_lat_deg' and 'datum_lon_deg' must be set together")
    return FilterConfig(
        imu_rate_hz=float(p["imu_rate_hz"]), gps_rate_hz=float(p["gps_rate_hz"]),
        filter_rate_hz=float(p["filter_rate_hz"]), alignment_time_s=float(p["alignment_time_s"]),
        min_alignment_time_s=float(p["min_alignment_time_s"]),
        stationary_gyro=p["stationary_gyro_dps"] * DEG, stationary_accel=p["stationary_accel_mg"] * MG,
        alignment_mode=str(p["alignment_mode"]), motion_window_s=float(p["motion_alignment_window_s"]),
        motion_max_accel=float(p["motion_alignment_max_accel_mps2"]),
        motion_gyro_bias=bool(p["motion_alignment_gyro_bias"]),
        initial_roll=float(p["initial_roll_deg"]) * DEG, initial_pitch=float(p["initial_pitch_deg"]) * DEG,
        initial_yaw=float(p["initial_yaw_deg"]) * DEG, heading_min_speed=float(p["heading_min_speed_mps"]),
        datum=(p["datum_lat_deg"], p["datum_lon_deg"], p["datum_h_m"]) if has_lat else None,
        lever_arm_b=(p["lever_arm_x_m"], p["lever_arm_y_m"], p["lever_arm_z_m"]),
        gps_std=float(p["gps_std_m"]), gps_std_up=float(p["gps_std_up_m"]), min_gps_std=float(p["min_gps_std_m"]),
        gate_probability=float(p["gate_probability"]), reuse_last_fix=bool(p["reuse_last_fix"]),
        max_rejected_fixes=int(p["max_rejected_fixes"]),
        zupt_enabled=bool(p["zupt_enabled"]), zupt_std=float(p["zupt_std_mps"]),
        zupt_std_outage=float(p["zupt_std_outage_mps"]),
        zupt_gate_probability=float(p["zupt_gate_probability"]),
        zupt_max_gps_speed=float(p["zupt_max_gps_speed_mps"]),
        zupt_max_ins_speed=float(p["zupt_max_ins_speed_mps"]),
        zupt_max_ins_speed_outage=float(p["zupt_max_ins_speed_outage_mps"]),
        nhc_enabled=bool(p["nhc_enabled"]), nhc_std=float(p["nhc_std_mps"]),
        nhc_gate_probability=float(p["nhc_gate_probability"]),
        mounting_rpy=tuple(float(p[f"mounting_{a}_deg"]) * DEG for a in ("roll", "pitch", "yaw")),
        nhc_mounting=str(p["nhc_mounting"]), mounting_std=float(p["mounting_std_deg"]) * DEG,
        nhc_lever_arm_b=tuple(float(p[f"nhc_lever_arm_{a}_m"]) for a in "xyz"),
        odometer_enabled=bool(p["odometer_enabled"]), odometer_std=float(p["odometer_std_mps"]),
        odometer_scale_std=float(p["odometer_scale_std_pct"]) / 100.0,
        odometer_max_age=float(p["odometer_max_age_s"]), odometer_latency=float(p["odometer_latency_s"]),
        odometer_stuck_speed=float(p["odometer_stuck_speed_mps"]),
        estimate_scale_factors=bool(p["estimate_scale_factors"]),
        init_scale_factor_std=float(p["init_scale_factor_std_pct"]) / 100.0,
        init_gyro_bias_std=p["init_gyro_bias_std_dph"] * DEG_PER_H,
        init_accel_bias_std=p["init_accel_bias_std_mg"] * MG, init_attitude_std=p["init_attitude_std_deg"] * DEG,
        heading_std=p["heading_std_deg"] * DEG, flicker_correlation_time=float(p["flicker_correlation_time_s"]),
        bias_gm_per_axis=int(p["bias_gm_states_per_axis"]), bias_gm_band_max=float(p["bias_gm_band_max_s"]),
        time_jump=float(p["time_jump_s"]), max_bridged_gap=float(p["max_bridged_gap_s"]),
        bridge_accel_std=float(p["bridge_accel_std_mps2"]), bridge_rate_std=float(p["bridge_rate_std_dps"]) * DEG,
        apply_calibration=bool(p["apply_sensor_model_calibration"]), max_speed=float(p["max_speed_mps"]),
        max_accel=float(p["max_accel_mps2"]), imu_max_gyro=float(p["imu_max_gyro_dps"]) * DEG,
        imu_max_accel=float(p["imu_max_accel_mps2"]))


WILDCARD_SECTIONS = ("**", "*")
"""Section names (after stripping '/') that apply to every node, as rcl reads a params file."""


def read_params_file(path) -> dict:
    """A ROS 2 params file as a mapping; FilterConfigError naming the file when it is missing or not a mapping."""
    data = read_yaml_file(path, FilterConfigError, "params file") or {}
    if not isinstance(data, dict):
        raise FilterConfigError(f"{path}: expected a mapping with '{NODE_NAME}: ros__parameters:'")
    return data


def node_section(data: dict, where, node: str = NODE_NAME) -> tuple[dict, set] | None:
    """The filter node's ``ros__parameters`` in a params-file mapping as rcl applies them: the wildcard sections
    (``/**``, ``/*``) first, then the node's own (``ins_gps_kf_node`` or ``/ins_gps_kf_node``), which wins.

    Returns (name -> value, names only a wildcard section gives), or None when no section applies; the one
    rule for the node, ``ins-gps-kf replay --params`` and nav-demo's report.
    """
    values, own = {}, set()
    for key in sorted(data, key=lambda k: str(k).strip("/") not in WILDCARD_SECTIONS):  # wildcards first
        name = str(key).strip("/")
        if name not in WILDCARD_SECTIONS + (node,):
            continue
        section = (data[key] or {}).get("ros__parameters") if isinstance(data[key], dict) else None
        if not isinstance(section, dict):
            raise FilterConfigError(f"{where}: expected '{key}: ros__parameters:' mapping")
        values.update(section)
        if name == node:
            own |= set(section)
    return (values, set(values) - own) if values or own else None


def load_params_yaml(path) -> dict:
    """The filter's parameters of a ROS 2 params file (:func:`node_section`) as name -> value, validated: a name
    under the node's own section must be a parameter; one only a wildcard section gives is shared, and skipped."""
    path = Path(path)
    found = node_section(read_params_file(path), path)
    if found is None:
        raise FilterConfigError(f"{path}: expected '{NODE_NAME}: ros__parameters:' mapping")
    section, shared = found
    unknown = set(section) - set(SPEC_BY_NAME) - NODE_ONLY - shared
    if unknown:
        raise FilterConfigError(unknown_keys_error(f"{path}: {NODE_NAME}.ros__parameters", unknown,
                                                   set(SPEC_BY_NAME) | NODE_ONLY))
    section = {k: v for k, v in section.items() if k in SPEC_BY_NAME}
    out = {k: (float(v) if isinstance(SPEC_BY_NAME[k].default, float) and isinstance(v, int)
               and not isinstance(v, bool) else v) for k, v in section.items()}
    for name, value in out.items():  # each value judged at load, the error naming the file
        try:
            check(name, value)
        except FilterConfigError as err:
            raise FilterConfigError(f"{path}: {err}") from None
    return out
