"""Shared basics of the MEMS navigation stack.

Conventions, stated once for every package:

* Units are SI inside: rad, rad/s, m/s, m/s^2, s. Degrees, g and deg/h appear
  only at the edges (config files, reports) and are converted with
  :mod:`nav_core.units`.
* Frames follow REP-103: body x forward, y left, z up (FLU); navigation frame
  ENU (x east, y north, z up). The body-to-ENU rotation is
  ``R = Rz(yaw) Ry(pitch) Rx(roll)``, yaw 0 = east, counter-clockwise.
* Names say the frame: ``velocity_n`` is in ENU, ``mat_nb`` maps body to ENU.
* Quaternions are ``(x, y, z, w)`` (ROS and SciPy order) everywhere.
* Randomness enters as an ``rng`` argument (``np.random.default_rng``).

Modules: :mod:`units`, :mod:`frames`, :mod:`earth`, :mod:`sensor_model`,
:mod:`recording` (with :mod:`bagio`, :mod:`mcap_scan` and :mod:`timestamps`), :mod:`datasets`
(external formats), :mod:`params` (ROS glue in :mod:`params_ros`), :mod:`cli` and :mod:`outputs` (what
every command-line tool shares), :mod:`imu_cdr` (Imu wire format for whole batches), :mod:`processes`.
Only :mod:`nav_core.ros_node` imports rclpy; IMU nodes take and publish Imu
through its ``ImuBatchSubscription`` / ``publish_imu_batch`` (raw CDR batches),
because at 1 kHz one rclpy callback and message object per sample cost more
than the navigation arithmetic.
"""
