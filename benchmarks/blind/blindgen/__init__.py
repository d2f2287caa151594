"""Blind validation generator for ``imu-sim diagnose`` (issue 24).

Written from ``../shared/DESIGN.md``'s conventions, the user documentation of the CLI and the
sensor-model schema only: it shares no code with ``imu_sim`` and imports nothing from it.
Frames: body FLU, navigation ENU, body-to-ENU ``R = Rz(yaw) Ry(pitch) Rx(roll)``; SI units inside.
"""
