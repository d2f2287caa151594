"""Parameter declarations without ROS: name, default, description with unit, range or choices.

The nodes declare these through :func:`nav_core.params_ros.declare_parameters` (the ROS glue);
ROS-free cores (the filter's config, the offline tools) validate the same declarations with
:meth:`Param.check`, so a value is judged the same way on the command line, in a params file
and in a node.
"""
from __future__ import annotations

import difflib
import math
from dataclasses import dataclass
from pathlib import Path

import yaml


class ConfigError(ValueError):
    """A parameter value is invalid; the node stops with this message (exit 2)."""


def did_you_mean(name: str, known) -> str:
    """`` (did you mean 'x'?)`` for the closest of ``known`` to ``name``, else an empty string."""
    close = difflib.get_close_matches(str(name), [str(k) for k in known], n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def read_yaml_file(path, error: type[Exception], kind: str):
    """The parsed YAML of ``path``; ``error`` naming the file when it is missing, a folder or not YAML.

    ``kind`` names the file in the message ("sensor-model file", "params file").
    """
    path = Path(path)
    try:
        return yaml.safe_load(path.read_text())
    except FileNotFoundError:
        raise error(f"{path}: {kind} not found") from None
    except IsADirectoryError:
        raise error(f"{path}: is a folder, expected a {kind}") from None
    except (yaml.YAMLError, UnicodeDecodeError) as err:
        raise error(f"{path}: not valid YAML: {' '.join(str(err).split())}") from None


def unknown_keys_error(where: str, unknown, known) -> str:
    """One line naming ``where``, the unknown key(s), a suggestion and the known keys."""
    unknown = sorted(map(str, unknown))
    hint = did_you_mean(unknown[0], known) if len(unknown) == 1 else ""
    return f"{where}: unknown key(s) {unknown}{hint}; known: {sorted(map(str, known))}"


def _number(value) -> str:
    """``value`` for a message: integers as integers (4000000, not 4e+06)."""
    value = float(value)
    return str(int(value)) if value.is_integer() and abs(value) < 1e15 else f"{value:g}"


@dataclass(frozen=True)
class Param:
    """A parameter declaration: name, default, description, optional numeric range or choices.

    The default's type is the parameter's type (bool, int, float or str). A NaN value is
    accepted only where the default is NaN (NaN means "unset" there); +-inf only where the
    default is infinite.
    """

    name: str
    default: object
    description: str
    low: float | None = None
    high: float | None = None
    choices: tuple | None = None

    def allowed(self) -> str:
        """The allowed values in words, for messages."""
        if self.choices:
            return f"one of {list(self.choices)}"
        kind = type(self.default).__name__
        if self.low is not None or self.high is not None:
            low = "-inf" if self.low is None else _number(self.low)
            high = "inf" if self.high is None else _number(self.high)
            return f"{kind} in [{low}, {high}]"
        return kind

    def check(self, value) -> None:
        """Raise ConfigError (naming the parameter and the allowed range) if ``value`` is not allowed."""
        bad = f"parameter '{self.name}': {value!r} is not allowed; expected {self.allowed()}"
        default = self.default
        if isinstance(default, bool):
            if not isinstance(value, bool):
                raise ConfigError(bad)
        elif isinstance(default, (int, float)):
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ConfigError(bad)
            if isinstance(default, int) and isinstance(value, float):
                raise ConfigError(bad)
            if math.isnan(value):
                if not (isinstance(default, float) and math.isnan(default)):
                    raise ConfigError(bad)
                return
            if math.isinf(value) and not (isinstance(default, float) and math.isinf(default)):
                raise ConfigError(bad)
            if (self.low is not None and value < self.low) or (self.high is not None and value > self.high):
                raise ConfigError(bad)
        elif isinstance(default, str) and not isinstance(value, str):
            raise ConfigError(bad)
        if self.choices and value not in self.choices:
            raise ConfigError(bad)
