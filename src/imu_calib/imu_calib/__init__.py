"""Deterministic IMU calibration, Allan variance noise model, sensor-model YAML."""
