"""The README's "Common tasks" run as written (issue 30): every command of their fenced bash blocks, on the shared
recordings, so the README cannot drift from the code.

A command runs in a scratch workspace laid out like the repository (``.venv``, ``config`` and ``src`` linked, the
real recordings at ``../shared/data``), from its root, in the order the README gives (a later recipe may use an
earlier one's output, as a user would). A tool must exit 0. A node (an executable whose module is a ``*_node``)
runs until stopped, so it must say it is ready and still be running a moment later. ``ros2 launch`` has no CLI
here (ROS 2 from PyPI has no ``ros2``): the launch file itself is loaded with stand-ins for launch/launch_ros, as
``test_nav_bringup_description`` does, and the nodes it would start are started as processes with the parameters it
gives them (``nav_bringup.graph.Graph``, the pip-only launch stand-in), each of which must become ready. A ``sudo``
command runs without sudo when the test is root; otherwise it is left out and the test says so (skip) at the end.
"""
from __future__ import annotations

import ast
import os
import re
import shlex
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from conftest import REPO, SHARED_DATA, console_scripts

README = REPO / "README.md"
SECTION = "## Common tasks"
LAUNCH_DIR = "launch"


@dataclass
class Recipe:
    """One ``###`` recipe of the common tasks: its title and its commands (continuation lines joined)."""

    title: str
    commands: list = field(default_factory=list)


def common_tasks(text: str) -> list[Recipe]:
    """The recipes under ``## Common tasks`` with the commands of their fenced bash blocks."""
    start = text.index(SECTION)
    end = text.find("\n## ", start + len(SECTION))
    section = text[start:end if end > 0 else None]
    recipes = []
    for part in re.split(r"\n### ", section)[1:]:
        title, _, body = part.partition("\n")
        recipe = Recipe(title.strip())
        for block in re.findall(r"```bash\n(.*?)```", body, flags=re.S):
            joined = re.sub(r"\\\n\s*", "", block)
            lines = [ln.strip() for ln in joined.splitlines()]
            recipe.commands += [ln for ln in lines if ln and not ln.startswith("#")]
        recipes.append(recipe)
    return recipes


def is_node(program: str, scripts: dict) -> bool:
    """Whether a console script is a ROS node (runs until stopped)."""
    return scripts.get(program, ":").split(":")[0].endswith("_node")


def launch_arguments(package: str, launch_file: str) -> dict:
    """The arguments ``src/<package>/launch/<launch_file>`` declares, name -> default (ARGUMENTS, read statically)."""
    tree = ast.parse((REPO / "src" / package / LAUNCH_DIR / launch_file).read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "ARGUMENTS" for t in node.targets):
            return {entry[0]: entry[1] for entry in ast.literal_eval(node.value)}
    raise AssertionError(f"{launch_file}: no ARGUMENTS tuple")


RECIPES = common_tasks(README.read_text())


# -- what the README must offer, checked without running anything (unit tier) -------------------------------------

def test_the_common_tasks_hold_the_four_recipes_a_newcomer_comes_for():
    titles = [r.title.lower() for r in RECIPES]
    for words in (("calibrate", "static"), ("own bag",), ("simulation", "recording"), ("hardware",)):
        assert any(all(w in t for w in words) for t in titles), (words, titles)
    for recipe in RECIPES:
        if not recipe.title.lower().startswith("more as they land"):
            assert recipe.commands, f"recipe {recipe.title!r} has no command"


def test_every_recipe_command_is_a_workspace_executable_or_ros2_launch():
    scripts = console_scripts()
    for recipe in RECIPES:
        for command in recipe.commands:
            words = shlex.split(command)
            if words[:2] == ["ros2", "launch"]:
                package, launch_file, *args = words[2:]
                declared = launch_arguments(package, launch_file)
                for arg in args:
                    assert arg.split(":=")[0] in declared, (command, sorted(declared))
            else:
                words = words[1:] if words[0] == "sudo" else words
                assert words[0].startswith(".venv/bin/"), command
                assert Path(words[0]).name in scripts, (command, sorted(scripts))


def test_the_readme_s_images_are_committed_and_small():
    images = re.findall(r"!\[[^]]*\]\(([^)]+)\)", README.read_text())
    assert images
    for image in images:
        path = REPO / image
        assert path.is_file() and path.stat().st_size < 200_000, (image, path.stat().st_size if path.exists() else None)


# -- the recipes run (slow: they convert, replay and diagnose real recordings, and start nodes) -------------------

@pytest.fixture
def workspace(tmp_path):
    """A folder laid out like the repository, with the real recordings at ../shared/data."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"real data not found: looked for {SHARED_DATA}")
    ws = tmp_path / "repo"
    ws.mkdir()
    for name in (".venv", "config", "src"):
        (ws / name).symlink_to(REPO / name)
    (tmp_path / "shared").mkdir()
    (tmp_path / "shared" / "data").symlink_to(SHARED_DATA)
    return ws


def _run_tool(command: str, ws: Path, env: dict) -> None:
    """Runs a tool to exit 0; a two-host drive with a link cut is also checked as test_nav_bringup_two_hosts does,
    a recording played through nav-demo as test_nav_bringup_recording_start does."""
    from test_nav_bringup_recording_start import check_recording_run, recording_run
    from test_nav_bringup_two_hosts import check_two_hosts_run, two_hosts_cut

    done = subprocess.run(["bash", "-c", command], cwd=ws, env=env, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, f"{command}\nexit {done.returncode}\n{done.stdout[-2000:]}\n{done.stderr[-3000:]}"
    cut = two_hosts_cut(command)
    if cut:
        at_s, for_s, out, duration_s = cut
        check_two_hosts_run(done.stdout, ws / out, at_s, for_s, duration_s)
    played = recording_run(command)
    if played:
        check_recording_run(done.stdout, ws / played[0], ws / played[1])


def _run_node(command: str, ws: Path, env: dict) -> None:
    from nav_core.processes import NodeProcess

    program, *args = shlex.split(command)
    proc = NodeProcess(Path(program).name, args, env=env, cwd=ws)
    try:
        assert proc.wait_for_line("ready", 60.0), f"{command}\nnot ready:\n{proc.output[-3000:]}"
        time.sleep(2.0)
        assert proc.proc.poll() is None, f"{command}\nexited {proc.proc.returncode}:\n{proc.output[-3000:]}"
    finally:
        code = proc.stop()
    assert code == 0, f"{command}\nexit {code} on SIGINT:\n{proc.output[-3000:]}"


def _run_launch(command: str, ws: Path, env: dict, monkeypatch) -> None:
    """``ros2 launch`` without the CLI: the launch file's own graph (its ``graph_inputs`` of the command's arguments
    and its params file), started by the pip-only runner; every node must become ready and stay up."""
    import importlib.util

    from nav_bringup.description import navigation_graph
    from nav_bringup.graph import Graph
    from test_nav_bringup_description import _fake_launch_modules

    _, _, package, launch_file, *args = shlex.split(command)
    values = dict(launch_arguments(package, launch_file), **dict(a.split(":=", 1) for a in args))
    monkeypatch.chdir(ws)  # relative paths (the command line's, bag_out's) are the user's working folder's
    _fake_launch_modules(monkeypatch, values, ws)  # the package's share folder = the workspace (config/)
    path = REPO / "src" / package / LAUNCH_DIR / launch_file
    spec = importlib.util.spec_from_file_location("launch_under_test", path)
    launch = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(launch)
    specs = navigation_graph(launch.graph_inputs(values, str(ws)))
    for node in specs:
        if node.overrides.get("sensor_model_path"):
            assert (ws / node.overrides["sensor_model_path"]).is_file(), (node.executable, node.overrides)
    graph = Graph(specs, env, params_file=ws / "config" / "navigation.yaml")
    try:
        graph.start(timeout_s=60.0)
        time.sleep(2.0)
        assert not graph.dead(), graph.dead()
    finally:
        codes = graph.stop()
    assert all(code == 0 for code in codes.values()), codes


def independent_groups(recipes: list[Recipe]) -> list[list[Recipe]]:
    """The recipes in groups that share no ``out/<name>`` path (README order kept within and between groups): a
    recipe that reads an earlier one's output runs after it in one workspace; unrelated ones run side by side."""
    groups: list[tuple[set, list]] = []
    for recipe in recipes:
        paths = {m for c in recipe.commands for m in re.findall(r"\bout/[\w.-]+", c)}
        joined = [g for g in groups if g[0] & paths]
        merged = (set(paths).union(*(g[0] for g in joined)), [r for g in joined for r in g[1]] + [recipe])
        groups = [g for g in groups if not any(g is j for j in joined)] + [merged]
    return sorted((sorted(g[1], key=recipes.index) for g in groups), key=lambda g: recipes.index(g[0]))


GROUPS = [g for g in independent_groups(RECIPES) if any(r.commands for r in g)]


def test_recipes_reading_an_earlier_recipes_output_share_its_group():
    a = Recipe("make", ["tool --out out/model"])
    b = Recipe("other", ["tool --out out/fleet"])
    c = Recipe("use", ["tool --model out/model/sensor_model.yaml --out out/use"])
    assert independent_groups([a, b, c]) == [[a, c], [b]]


@pytest.mark.slow
@pytest.mark.ros
@pytest.mark.parametrize("group", GROUPS, ids=["-".join(re.findall(r"[a-z]+", g[0].title.lower())[:4]) for g in GROUPS])
def test_the_common_tasks_run_as_written(group, workspace, ros_env, monkeypatch):
    scripts = console_scripts()
    env = dict(ros_env, OPENBLAS_NUM_THREADS="1")
    needs_root = []
    for recipe in group:
        for command in recipe.commands:
            if command.startswith("sudo "):  # as root the command itself; else it cannot run here
                if os.geteuid() != 0:
                    needs_root.append(command)
                    continue
                command = command[len("sudo "):]
            program = shlex.split(command)[0]
            if program == "ros2":
                _run_launch(command, workspace, env, monkeypatch)
            elif is_node(Path(program).name, scripts):
                _run_node(command, workspace, env)
            else:
                _run_tool(command, workspace, env)
    if needs_root:
        pytest.skip(f"every other command ran; these need root: {needs_root}")
