"""Shared basics: units, frames, WGS-84 Earth model, sensor-model YAML schema, recording IO."""
