"""ROS glue of :mod:`nav_core.params`: descriptors and declaration with range checks on a node.

A value out of range (``-p hop:=-3``), of the wrong type (``-p baud:=fast``) or refused by
rclpy itself becomes one :class:`~nav_core.params.ConfigError` naming the parameter and the
allowed range; :func:`nav_core.ros_node.run_node` prints it as one line and exits 2. So does a
value for a parameter the node does not have (``-p hopp:=3``), unless only a params file's
wildcard section gives it (a warning: that section is shared by several nodes).
"""
from __future__ import annotations

import sys
from pathlib import Path

import yaml
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
    check_unknown_overrides(node, by_name)

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


def check_unknown_overrides(node, known, args=None) -> list:
    """ConfigError for a value given to ``node`` for a parameter it does not have; returns the ones only warned about.

    rclpy ignores such values silently (a typo, or a parameter that was removed), so a ``-p``
    value, a key under the node's own name in a params file or a constructor override is an error
    (one line naming it, with a did-you-mean). A key that only a wildcard section (``/**:``) of a
    params file gives is logged as a warning: such a section is shared by several nodes. ``args``
    is the process's command line (default ``sys.argv``, what ``rclpy.init`` parses).
    """
    declared = set(getattr(node, "_parameters", {}))
    unknown = sorted(name for name in getattr(node, "_parameter_overrides", {})
                     if name not in declared and not name.startswith("qos_overrides."))
    shared = shared_only_keys(sys.argv if args is None else args)
    errors = [name for name in unknown if name not in shared]
    if errors:
        hint = did_you_mean(errors[0], known) if len(errors) == 1 else ""
        raise ConfigError(f"unknown parameter(s) {errors} for {node.get_name()}{hint} (given with -p or under "
                          f"the node's name in a params file); known: {sorted(known)}")
    warned = [name for name in unknown if name in shared]
    for name in warned:
        node.get_logger().warning(f"parameter '{name}' (from a params file's wildcard section) is not a "
                                  f"parameter of {node.get_name()}, ignored{did_you_mean(name, known)}")
    return warned


def shared_only_keys(args) -> set:
    """Parameter names that only wildcard sections (``/**``, ``/*``) of the ``--params-file`` files in ``args`` give.

    A name also given with ``-p`` or under a node's own name is not among them. A file that
    cannot be read gives nothing (rcl has refused it before a node exists).
    """
    shared, own = set(), set()
    for flag, value in _ros_arg_pairs(args):
        if flag in ("-p", "--param") and ":=" in value:
            own.add(value.split(":=", 1)[0].rsplit(":", 1)[-1])  # [node:]name:=value
        elif flag == "--params-file":
            try:
                data = yaml.safe_load(Path(value).read_text())
            except (OSError, yaml.YAMLError):
                continue
            for pattern, names in _sections(data, ()):
                (shared if pattern[-1].strip("/") in ("*", "**") else own).update(names)
    return shared - own


_VALUED_FLAGS = frozenset({"-p", "--param", "--params-file", "-r", "--remap", "-e", "--enclave", "--log-level",
                           "--log-config-file", "--log-file-name"})


def _ros_arg_pairs(args):
    """(flag, value) pairs of the ``--ros-args`` parts of a command line."""
    inside, flag = False, None
    for token in map(str, args or ()):
        if token == "--ros-args":
            inside, flag = True, None
        elif token == "--":
            inside = False
        elif inside and flag is not None:
            yield flag, token
            flag = None
        elif inside and token in _VALUED_FLAGS:  # the others (--enable-rosout-logs...) take no value
            flag = token


def _sections(data, path):
    """(node pattern as a tuple of names, parameter names) for each ``ros__parameters`` section of a params file."""
    if not isinstance(data, dict):
        return
    for key, value in data.items():
        if key == "ros__parameters" and path:
            yield path, set(_flat_names(value, ""))
        else:
            yield from _sections(value, path + tuple(str(key).strip("/").split("/")))


def _flat_names(value, prefix):
    """Parameter names in a ``ros__parameters`` mapping, nested ones joined with dots (as rcl does)."""
    if not isinstance(value, dict):
        yield prefix
        return
    for key, sub in value.items():
        yield from _flat_names(sub, f"{prefix}.{key}" if prefix else str(key))


def init_error_line(err: Exception) -> str:
    """rcl's error for bad ``--ros-args`` (an unreadable params file...) on one line, without C source places."""
    import re

    text = re.sub(r",? at /\S+:\d+", "", " ".join(str(err).split()))
    return text or type(err).__name__
