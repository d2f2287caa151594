"""Every console script of the workspace, and every sub-command, answers ``--help`` with one line saying what it is
for and ends with an example that uses its real options (issue 30).

The scripts are found in ``src/*/setup.py`` (a new one is checked as soon as it is declared); sub-commands are read
from the ``{a,b,...}`` choices of each usage line. Each ``main`` is called in this process (the nodes print their
help before ``rclpy.init``); one node and one tool are also run as installed executables.
"""
from __future__ import annotations

import importlib
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import console_scripts


SCRIPTS = console_scripts()


def help_of(target: str, argv: list, capsys) -> str:
    """What ``main(argv + ['--help'])`` prints; it must exit 0."""
    module, func = target.split(":")
    main = getattr(importlib.import_module(module), func)
    try:
        code = main([*argv, "--help"])
    except SystemExit as done:
        code = done.code
    out = capsys.readouterr().out
    assert code in (0, None), (target, argv, code, out)
    return out


def subcommands(text: str) -> list:
    """The sub-commands a help text's usage line offers (``{a,b}``), in order."""
    usage = text.split("\n\n")[0]
    found = re.search(r"\{([\w,-]+)\} \.\.\.", usage)  # a sub-command takes the rest: "{a,b} ..."
    return found.group(1).split(",") if found else []


def check_help(text: str, command: str) -> None:
    """One line of purpose after the usage block; an example block at the end that runs ``command`` with its
    real options."""
    assert text.startswith("usage:"), text[:200]
    blocks = [b for b in re.split(r"\n\s*\n", text.strip()) if b.strip()]
    purpose = blocks[1].splitlines()
    assert len(purpose) == 1, f"{command}: the text after usage must start with one line of purpose:\n{blocks[1]}"
    assert purpose[0].strip() and len(purpose[0]) <= 120 and purpose[0].rstrip().endswith("."), (command, purpose)
    last = blocks[-1].splitlines()
    assert last[0].strip() in ("example:", "examples:"), f"{command}: help must end with an example:\n{blocks[-1]}"
    examples = [ln.strip() for ln in last[1:]]
    assert examples and all(e.startswith(command + " ") or e == command for e in examples), (command, examples)
    for example in examples:
        words = shlex.split(example)
        for word in words:
            if word.startswith("--") and word != "--ros-args":
                assert re.search(rf"(^|[\s\[,]){re.escape(word.split('=')[0])}\b", text), (command, word)
        for i, word in enumerate(words[:-1]):
            if word == "-p":  # a node's parameter must be one it declares
                name = words[i + 1].split(":=")[0]
                assert re.search(rf"^  {re.escape(name)} \(", text, re.M), (command, name)


def test_every_console_script_is_found():
    assert {"imu-calib", "imu-sim", "ins-gps-kf", "nav-demo", "nav-convert", "wmra-report", "bp3010_emulator",
            "bp3010_driver", "wmra_node", "ins_gps_kf_node"} <= set(SCRIPTS)


@pytest.mark.parametrize("name", sorted(SCRIPTS))
def test_help_says_what_it_is_for_and_ends_with_an_example(name, capsys):
    text = help_of(SCRIPTS[name], [], capsys)
    check_help(text, name)
    for sub in subcommands(text):
        check_help(help_of(SCRIPTS[name], [sub], capsys), f"{name} {sub}")


@pytest.mark.parametrize("name", ["bp3010_driver", "bp3010_emulator"])
def test_the_installed_executables_print_the_same_help(name, capsys):
    exe = Path(sys.executable).parent / name
    done = subprocess.run([str(exe), "--help"], capture_output=True, text=True, timeout=60,
                          env={"COLUMNS": "80", "PATH": str(exe.parent)})
    assert done.returncode == 0, done.stderr
    check_help(done.stdout, name)
