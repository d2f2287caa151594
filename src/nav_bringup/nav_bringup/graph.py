"""Process runner for pip-only installs (the stand-in for ``ros2 launch``): start, watch and stop a node graph.

Each node is its own process on DDS, started from its executable with the one
params file (``config/navigation.yaml``) plus per-run overrides, exactly as
``launch/navigation.launch.py`` starts them on a full ROS 2 install.
"""
from __future__ import annotations

import time
from pathlib import Path

from nav_bringup.description import NodeSpec  # noqa: F401  (re-exported: the runner starts these)
from nav_core.processes import NodeProcess
from nav_core.workspace import workspace_root

REPO = workspace_root()  # $MEMS_NAV_ROOT, or the current folder or a parent holding config/navigation.yaml
PARAMS_FILE = REPO / "config" / "navigation.yaml"


class GraphError(RuntimeError):
    """A node did not start or died; the message carries its output, ``exit_code`` the node's (None: running)."""

    def __init__(self, message: str, exit_code: int | None = None):
        super().__init__(message)
        self.exit_code = exit_code


class Graph:
    """A set of node processes sharing one environment (ROS_DOMAIN_ID) and params file."""

    def __init__(self, specs, env: dict, params_file: Path = PARAMS_FILE, log_dir: Path | None = None,
                 prefix=None, progress=None):
        """``prefix(executable)``: the command prefix that starts a node on its host (:mod:`nav_bringup.hosts`);
        ``progress(text)``: told as each node becomes ready (starting the graph takes tens of seconds)."""
        self.progress = progress or (lambda text: None)
        self.specs = list(specs)
        self.prefix = prefix or (lambda executable: ())
        self.env = env
        self.params_file = params_file
        self.log_dir = log_dir
        self.procs: dict[str, NodeProcess] = {}

    def start(self, timeout_s: float = 60.0) -> None:
        """Start every node in order and wait for each to say it is ready."""
        started = time.monotonic()
        for k, spec in enumerate(self.specs, 1):
            remaps = [a for src, dst in spec.remaps for a in ("-r", f"{src}:={dst}")]
            args = (*spec.args, "--ros-args", *remaps, "--") if remaps else spec.args
            proc = NodeProcess(spec.executable, args, env=self.env, params_file=self.params_file,
                               ros_args=spec.overrides, prefix=self.prefix(spec.executable))
            self.procs[spec.executable] = proc
            if not proc.wait_for_line(spec.ready, timeout_s):
                code = proc.proc.poll()
                why = f"exited with code {code} before it was ready" if code is not None and code >= 0 else \
                    f"did not become ready within {timeout_s} s (exit {code})"
                self.stop()
                raise GraphError(f"{spec.executable} {why}:\n{proc.output[-3000:]}", code)
            self.progress(f"{spec.executable} ready ({k}/{len(self.specs)}, {time.monotonic() - started:.0f} s)")

    def dead(self) -> dict:
        """Nodes that have exited: executable -> exit code."""
        return {name: p.proc.poll() for name, p in self.procs.items() if p.proc.poll() is not None}

    def wait_for_exit(self, executable: str, timeout_s: float) -> int | None:
        """Wait for one node to exit by itself; its exit code, or None on timeout."""
        deadline = time.monotonic() + timeout_s
        proc = self.procs[executable].proc
        while time.monotonic() < deadline:
            if proc.poll() is not None:
                return proc.returncode
            time.sleep(0.2)
        return None

    def stop(self) -> dict:
        """Stop every node (reverse order, SIGINT then SIGKILL); write logs; return exit codes."""
        codes = {}
        for name in reversed(list(self.procs)):
            codes[name] = self.procs[name].stop()
            if self.log_dir:
                self.log_dir.mkdir(parents=True, exist_ok=True)
                (self.log_dir / f"{name}.log").write_text(self.procs[name].output)
        return codes
