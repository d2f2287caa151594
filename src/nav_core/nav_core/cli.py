"""What every command-line tool shares: ``--debug``, ``--force``, number arguments with ranges, one-line errors.

A user error (a bad file, value or path: ``ValueError`` and its kin such as
``RecordingError``, ``SensorModelError``, ``ConfigError``, ``OutputError``, or an
``OSError``) prints one line ``<prog>: error: <message>`` and exits 2. Anything else
is a bug: one line naming it and exit 1. ``--debug`` (or ``NAV_DEBUG=1``) shows the
traceback instead. Use::

    parser = argparse.ArgumentParser(prog="tool"); add_common(parser)
    ...
    return run_cli("tool", command, args)
"""
from __future__ import annotations

import argparse
import difflib
import math
import os
import struct
import sys

USER_ERRORS = (ValueError, OSError, struct.error)
"""Exception types that mean bad input, not a bug (all project error types derive from ValueError)."""


def add_common(parser: argparse.ArgumentParser, force: bool = False, sub: bool = False) -> None:
    """Add ``--debug`` (and ``--force`` when the command writes outputs) to ``parser``.

    ``sub=True`` for subparsers: the option may then be given before or after the subcommand.
    """
    default = argparse.SUPPRESS if sub else False
    parser.add_argument("--debug", action="store_true", default=default,
                        help="show the full traceback of an error (also NAV_DEBUG=1)")
    if force:
        parser.add_argument("--force", action="store_true", default=False,
                            help="replace an existing --out (it is only removed once the new one is complete)")


def parse_args(parser: argparse.ArgumentParser, argv=None) -> argparse.Namespace:
    """``parser.parse_args(argv)``, but an unknown option is a usage error (exit 2) of the subcommand given that
    names the closest known option (``'--no-plt': did you mean '--no-plot'?``)."""
    args, extra = parser.parse_known_args(argv)
    if not extra:
        return args
    target = parser
    for action in parser._actions:  # the subcommand's parser knows its options
        if isinstance(action, argparse._SubParsersAction) and getattr(args, action.dest, None) in action.choices:
            target = action.choices[getattr(args, action.dest)]
    known = [o for a in target._actions + parser._actions for o in a.option_strings if o.startswith("--")]
    hints = []
    for word in extra:
        close = difflib.get_close_matches(word.split("=")[0], known, n=1, cutoff=0.6)
        if word.startswith("-") and close:
            hints.append(f"{word.split('=')[0]!r}: did you mean {close[0]!r}?")
    target.error(f"unrecognized arguments: {' '.join(extra)}" + (f" ({'; '.join(hints)})" if hints else ""))


def number(low: float | None = None, high: float | None = None, integer: bool = False,
           low_open: bool = False):
    """An argparse ``type``: a finite number in [low, high] (``low_open``: > low), else a one-line usage error."""
    def parse(text: str):
        kind = "an integer" if integer else "a number"
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {kind}") from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"{text!r} must be finite")
        too_low = low is not None and (value <= low if low_open else value < low)
        if too_low or (high is not None and value > high):
            lo = "-inf" if low is None else f"{low:g}"
            hi = "inf" if high is None else f"{high:g}"
            raise argparse.ArgumentTypeError(f"{text} is outside {'(' if low_open else '['}{lo}, {hi}]")
        return value
    return parse


def one_line(err: BaseException) -> str:
    """The message of ``err`` on one line."""
    text = str(err) or type(err).__name__
    if isinstance(err, OSError) and err.filename and str(err.filename) not in text:
        text = f"{err.filename}: {text}"
    return " | ".join(line.strip() for line in text.splitlines() if line.strip())


def debug_wanted(args=None) -> bool:
    """Whether ``--debug`` was given or ``NAV_DEBUG`` is set."""
    return bool(getattr(args, "debug", False)) or os.environ.get("NAV_DEBUG", "") not in ("", "0")


def run_cli(prog: str, func, args, user_errors=USER_ERRORS) -> int:
    """Run ``func(args)``: its return code, 2 for a user error, 1 for a bug, 130 on Ctrl-C (one line each)."""
    debug = debug_wanted(args)
    try:
        return func(args)
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return 130
    except user_errors as err:
        if debug:
            raise
        print(f"{prog}: error: {one_line(err)}", file=sys.stderr)
        return 2
    except Exception as err:  # a bug: still one line, unless asked for the traceback
        if debug:
            raise
        print(f"{prog}: internal error: {type(err).__name__}: {one_line(err)} (run with --debug for the traceback)",
              file=sys.stderr)
        return 1


def about(purpose: str, *examples: str) -> dict:
    """``ArgumentParser``/``add_parser`` keywords for a ``--help`` that starts with ``purpose`` (one line saying what
    the command is for, then any detail) and ends with ``examples``, both printed as written."""
    heading = "example:" if len(examples) == 1 else "examples:"
    return {"description": purpose, "epilog": "\n".join([heading, *(f"  {e}" for e in examples)]),
            "formatter_class": argparse.RawDescriptionHelpFormatter}


def help_wanted(argv) -> bool:
    """Whether ``-h``/``--help`` is among a node's own arguments (those before ``--ros-args``)."""
    argv = list(argv)
    own = argv[:argv.index("--ros-args")] if "--ros-args" in argv else argv
    return "-h" in own or "--help" in own


def node_help(prog: str, purpose: str, params, example: str) -> str:
    """A node's ``--help``: what it is for (one line), its parameters (``nav_core.params.Param``), an example."""
    lines = [f"usage: {prog} [--ros-args [--params-file FILE] [-p NAME:=VALUE ...] [-r FROM:=TO ...]]", "",
             purpose, "", "parameters (-p NAME:=VALUE, or the node's section of a params file such as "
             "config/navigation.yaml):"]
    for p in params:
        lines.append(f"  {p.name} ({p.allowed()}, default {p.default!r})")
        lines.append(f"      {p.description}")
    return "\n".join(lines + ["", "example:", f"  {example}"])
