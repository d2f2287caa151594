"""Parameter declarations without ROS: name, default, description with unit, range or choices.

The nodes declare these through :func:`nav_core.ros_node.declare_parameters`; ROS-free
cores (the filter's config, the offline tools) validate the same declarations.
"""
from __future__ import annotations

from dataclasses import dataclass


class ConfigError(ValueError):
    """A parameter value is invalid; the node stops with this message."""


@dataclass(frozen=True)
class Param:
    """A parameter declaration: name, default, description, optional numeric range or choices."""

    name: str
    default: object
    description: str
    low: float | None = None
    high: float | None = None
    choices: tuple | None = None

    def descriptor(self):
        """The ROS ``ParameterDescriptor`` with description and range (rcl_interfaces imported here only)."""
        from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor

        desc = ParameterDescriptor(description=self.description)
        if self.choices:
            desc.additional_constraints = f"one of {list(self.choices)}"
        if self.low is not None and self.high is not None:
            if isinstance(self.default, bool):
                pass
            elif isinstance(self.default, int):
                desc.integer_range = [IntegerRange(from_value=int(self.low), to_value=int(self.high), step=0)]
            elif isinstance(self.default, float):
                desc.floating_point_range = [FloatingPointRange(from_value=float(self.low),
                                                                to_value=float(self.high), step=0.0)]
        return desc

    def check(self, value) -> None:
        """Raise ConfigError if ``value`` is outside the range or choices."""
        if self.choices and value not in self.choices:
            raise ConfigError(f"parameter '{self.name}': {value!r} is not one of {list(self.choices)}")
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            if self.low is not None and value < self.low or self.high is not None and value > self.high:
                raise ConfigError(f"parameter '{self.name}': {value!r} outside [{self.low}, {self.high}]")
