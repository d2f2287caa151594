"""Start and stop node processes (the launch stand-in for pip-only installs) and read their output."""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path


def executable(name: str) -> str:
    """Path of a console script: next to this Python first (the venv), then PATH."""
    here = Path(sys.executable).parent / name
    if here.exists():
        return str(here)
    found = shutil.which(name)
    if not found:
        raise FileNotFoundError(f"executable {name!r} not found next to {sys.executable} or on PATH")
    return found


class NodeProcess:
    """One node executable as a child process; its combined output is collected line by line."""

    def __init__(self, name: str, args=(), env=None, ros_args=None, params_file=None, cwd=None, prefix=()):
        """``prefix``: a command that runs the node, e.g. ``("ip", "netns", "exec", NS)`` on another host."""
        cmd = [*prefix, executable(name), *map(str, args)]
        if ros_args or params_file:
            cmd.append("--ros-args")
            if params_file:
                cmd += ["--params-file", str(params_file)]
            for key, value in (ros_args or {}).items():
                cmd += ["-p", f"{key}:={_ros_value(value)}"]
        self.name = name
        self.cmd = cmd
        self.lines: list[str] = []
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                     env=env or dict(os.environ), cwd=cwd, start_new_session=True)
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self):
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))

    @property
    def output(self) -> str:
        """Everything the process printed so far."""
        return "\n".join(self.lines)

    def wait_for_line(self, text: str, timeout_s: float = 20.0) -> bool:
        """Wait until a printed line contains ``text``; False on timeout or exit."""
        deadline = time.monotonic() + timeout_s
        while True:
            if any(text in line for line in self.lines):
                return True
            if self.proc.poll() is not None:
                time.sleep(0.1)
                return any(text in line for line in self.lines)
            if time.monotonic() >= deadline:
                return False
            time.sleep(0.05)

    def stop(self, timeout_s: float = 10.0) -> int:
        """SIGINT, then SIGKILL after ``timeout_s``; returns the exit code."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
        self._reader.join(timeout=2.0)
        return self.proc.returncode


def _ros_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return value if value else "''"
    return str(value)
