"""ROS glue of :mod:`nav_core.params`: descriptors and declaration with range checks on a node.

A value out of range (``-p hop:=-3``), of the wrong type (``-p baud:=fast``) or refused by
rclpy itself becomes one :class:`~nav_core.params.ConfigError` naming the parameter and the
allowed range; :func:`nav_core.ros_node.run_node` prints it as one line and exits 2.
"""
from __future__ import annotations

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.exceptions import (InvalidParameterTypeException, InvalidParameterValueException,
                              ParameterException, ParameterUninitializedException)

from nav_core.params import ConfigError, Param, did_you_mean


def descriptor(p: Param, read_only: bool = False) -> ParameterDescriptor:
    """The ROS ``ParameterDescriptor`` of ``p``: description, range, choices as a constraint, read-only flag."""
    desc = ParameterDescriptor(description=p.description, read_only=read_only)
    if p.choices:
        desc.additional_constraints = f"one of {list(p.choices)}"
    if p.low is not None and p.high is not None and not isinstance(p.default, bool):
        if isinstance(p.default, int):
            desc.integer_range = [IntegerRange(from_value=int(p.low), to_value=int(p.high), step=0)]
        elif isinstance(p.default, float):
            desc.floating_point_range = [FloatingPointRange(from_value=float(p.low), to_value=float(p.high),
                                                            step=0.0)]
    return desc


def _override(node, name: str):
    """The value given for ``name`` on the command line or in a params file, if any (for messages)."""
    value = getattr(node, "_parameter_overrides", {}).get(name)
    return None if value is None else value.value


def declare_one(node, p: Param, read_only: bool = False):
    """Declare ``p`` on ``node`` and return its checked value; ConfigError for any bad value."""
    try:
        node.declare_parameter(p.name, p.default, descriptor(p, read_only))
        value = node.get_parameter(p.name).value
    except InvalidParameterTypeException:
        raise ConfigError(f"parameter '{p.name}': {_override(node, p.name)!r} has the wrong type; "
                          f"expected {p.allowed()}") from None
    except (InvalidParameterValueException, ParameterUninitializedException, ParameterException) as err:
        given = _override(node, p.name)
        raise ConfigError(f"parameter '{p.name}': {given!r} is not allowed; expected {p.allowed()}"
                          if given is not None else f"parameter '{p.name}': {err}") from None
    p.check(value)
    return value


def declare_parameters(node, params, dynamic=()) -> dict:
    """Declare ``params`` with descriptors, validate them (ConfigError), return name -> value.

    A parameter is read-only (``set_parameters`` is refused, "read-only") unless it is named in
    ``dynamic``: those the node applies at run time itself (its own on-set callback, or reading
    the parameter each time). So a change is applied or refused, never accepted and ignored.
    Changes to dynamic ones are validated by an on-set-parameters callback that rejects bad values.
    """
    by_name = {p.name: p for p in params}
    unknown = set(dynamic) - set(by_name)
    if unknown:
        raise ValueError(f"dynamic parameters {sorted(unknown)} are not declared")
    values = {p.name: declare_one(node, p, read_only=p.name not in dynamic) for p in params}
    warn_unknown_overrides(node, by_name)

    def on_set(changes):
        for change in changes:
            if change.name in by_name:
                try:
                    by_name[change.name].check(change.value)
                except ConfigError as err:
                    return SetParametersResult(successful=False, reason=str(err))
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(on_set)
    return values


def warn_unknown_overrides(node, known) -> list:
    """Log one warning per value given (``-p`` or params file) for a parameter the node does not have.

    rclpy ignores such values silently (a typo, or a parameter that was removed). A warning, not an
    error: launch files and params files shared by several versions may carry extra keys.
    """
    declared = set(getattr(node, "_parameters", {}))
    unknown = sorted(name for name in getattr(node, "_parameter_overrides", {})
                     if name not in declared and not name.startswith("qos_overrides."))
    for name in unknown:
        node.get_logger().warning(f"parameter '{name}' is not a parameter of {node.get_name()}, ignored"
                                  f"{did_you_mean(name, known)}")
    return unknown


def init_error_line(err: Exception) -> str:
    """rcl's error for bad ``--ros-args`` (an unreadable params file...) on one line, without C source places."""
    import re

    text = re.sub(r",? at /\S+:\d+", "", " ".join(str(err).split()))
    return text or type(err).__name__
