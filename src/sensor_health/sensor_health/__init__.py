"""Live sensor health: names a sensor fault (effect from a fixed vocabulary, channel, onset, estimate) from the
raw IMU while the vehicle drives, with thresholds from Monte Carlo on the sensor model's own noise.

Channels ``gx gy gz ax ay az``; SI units inside (s, rad/s, m/s^2, Hz). The core (every module but
``sensor_health_node``) has no ROS import and does not import the simulator.
"""
