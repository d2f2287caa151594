"""Each package's package.xml declares exactly what its code imports, under the rosdep key that installs it.

On a full ROS 2 install ``rosdep install --from-paths src`` reads these declarations; a missing one
leaves a module uninstalled, an unused one installs for nothing. Imports are read from every module
of the package and its launch files (function-level imports included).
"""
import ast
import sys
from pathlib import Path

import pytest
import yaml
from catkin_pkg.package import parse_package

SRC = Path(__file__).resolve().parents[1] / "src"
LOCAL_ROSDEP = SRC.parent / "rosdep" / "mems_nav.yaml"
PACKAGES = sorted(p.parent.name for p in SRC.glob("*/setup.py"))
WORKSPACE = {p.parent.name for p in SRC.glob("*/package.xml") if not (p.parent / "COLCON_IGNORE").exists()}

# Python module -> rosdep key. The keys are those of ros/rosdistro rosdep/python.yaml; where it has
# none (PyWavelets, rosbags, lz4, zstandard, dask, distributed) the key is defined in rosdep/mems_nav.yaml.
ROSDEP_KEYS = {
    "numpy": "python3-numpy", "scipy": "python3-scipy", "yaml": "python3-yaml",
    "matplotlib": "python3-matplotlib", "tqdm": "python3-tqdm", "serial": "python3-serial",
    "numba": "python3-numba", "filterpy": "python3-filterpy-pip", "pymap3d": "pymap3d-pip",
    "pywt": "python3-pywt", "rosbags": "python3-rosbags-pip", "lz4": "python3-lz4", "zstandard": "python3-zstandard",
    "dask": "python3-dask", "distributed": "python3-distributed",
}
# ROS 2 packages imported from Python: the key is the package name.
ROS_PACKAGES = {"rclpy", "rcl_interfaces", "builtin_interfaces", "std_msgs", "sensor_msgs", "nav_msgs",
                "geometry_msgs", "diagnostic_msgs", "rosgraph_msgs", "tf2_msgs", "launch", "launch_ros",
                "ament_index_python"}


def imported_modules(pkg: str) -> dict:
    """Top-level modules the package's code imports -> the first file importing each."""
    root = SRC / pkg
    files = sorted((root / pkg).rglob("*.py")) + sorted((root / "launch").glob("*.py"))
    found = {}
    for path in files:
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                names = [node.module]
            else:
                continue
            for name in names:
                found.setdefault(name.split(".")[0], path.relative_to(SRC))
    return {m: f for m, f in found.items() if m not in sys.stdlib_module_names and m not in ("__future__", pkg)}


def rosdep_key(module: str) -> str | None:
    """The rosdep key of an imported module, None when this test does not know it."""
    if module in WORKSPACE or module in ROS_PACKAGES:
        return module
    return ROSDEP_KEYS.get(module)


def run_dependencies(pkg: str) -> set:
    """Keys of the package's run-time dependencies (``depend``, ``exec_depend``)."""
    package = parse_package(str(SRC / pkg / "package.xml"))
    return {d.name for d in package.exec_depends + package.build_export_depends}


@pytest.mark.parametrize("pkg", PACKAGES)
def test_package_xml_declares_every_import_and_nothing_else(pkg):
    modules = imported_modules(pkg)
    unknown = {m: str(f) for m, f in modules.items() if rosdep_key(m) is None}
    assert not unknown, f"{pkg}: no rosdep key known for {unknown}; add it to ROSDEP_KEYS"
    needed = {rosdep_key(m): str(f) for m, f in modules.items()}
    declared = run_dependencies(pkg)
    missing = {k: f for k, f in needed.items() if k not in declared}
    unused = declared - set(needed)
    assert not missing, f"{pkg}/package.xml does not declare {missing} (key: first file importing it)"
    assert not unused, f"{pkg}/package.xml declares {sorted(unused)}, which its code never imports"


def test_every_key_resolves_upstream_or_in_the_local_rosdep_file():
    local = yaml.safe_load(LOCAL_ROSDEP.read_text())
    upstream = set(ROSDEP_KEYS.values()) - {"python3-pywt", "python3-rosbags-pip", "python3-lz4", "python3-zstandard",
                                          "python3-dask", "python3-distributed"}
    for pkg in PACKAGES:
        for key in run_dependencies(pkg):
            assert key in WORKSPACE | ROS_PACKAGES | upstream | set(local), f"{pkg}: rosdep key {key!r} resolves nowhere"
    for key, rules in local.items():
        assert set(rules) >= {"debian", "ubuntu"}, f"{LOCAL_ROSDEP.name}: {key} has no debian/ubuntu rule"
