"""Strapdown INS and loosely coupled INS/GPS error-state Kalman filter.

Conventions (as :mod:`nav_core`): SI units inside (rad, rad/s, m, m/s, m/s^2, s);
navigation frame ENU, body FLU (REP-103); body-to-ENU ``R = Rz(yaw) Ry(pitch) Rx(roll)``;
quaternions ``(x, y, z, w)``. Positions are in a local ENU frame (m) around a datum
(:class:`nav_core.earth.LocalFrame`), as the reference paper does to keep the
gain computation well conditioned.

Error state (pyins-style names, see :mod:`ins_gps_kf.error_model`): position,
velocity and attitude errors in ENU, gyro and accelerometer bias errors in body;
every error is *estimate minus truth*; the attitude error ``phi`` is defined by
``C_est = (I - [phi x]) C_true``.

Modules: :mod:`strapdown` (per-sample mechanization, numba), :mod:`alignment`,
:mod:`error_model`, :mod:`kalman`, :mod:`measurements`, :mod:`input_checks` (bad input,
counted in ``InsGpsFilter.input_counters``), :mod:`records`, :mod:`filter` (the life cycle and
the epoch, shared by the node and the replay) with its policies apart: :mod:`updates` (the update
models), :mod:`starts`, :mod:`gnss_policy`, :mod:`heading`, :mod:`bridging`; :mod:`odometry` and
:mod:`status` (what the node publishes), :mod:`offline` (``run``, ``to_trajectory``, ``load_model``),
:mod:`replay` (the ``ins-gps-kf`` CLI), :mod:`track_check` (do the fixes show the IMU's motion), :mod:`synthetic`
(closed-form test motions).
Only :mod:`ins_gps_kf_node` imports rclpy. The evaluations are the ``nav_eval`` package.
"""
