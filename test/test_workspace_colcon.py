"""The workspace is a real colcon workspace: valid package.xml files, colcon build, executables in lib/<pkg>."""
import ast
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from catkin_pkg.package import parse_package

REPO = Path(__file__).resolve().parents[1]
PACKAGES = sorted(p.parent.name for p in (REPO / "src").glob("*/setup.py"))  # ament_python; tf2_msgs is CMake
# tf2_msgs/msg/TFMessage's type hash in ROS 2 Jazzy (what `ros2 topic info -v /tf` shows): the message built here
# must be the same type, or a full ROS install's tf2 listeners would not match our /tf publisher.
TFMESSAGE_RIHS01 = "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"


def _console_scripts(pkg: str) -> list:
    """Executable names declared in a package's setup.py entry points."""
    tree = ast.parse((REPO / "src" / pkg / "setup.py").read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Dict):
            for key, value in zip(node.keys, node.values):
                if isinstance(key, ast.Constant) and key.value == "console_scripts":
                    return [ast.literal_eval(v).split("=")[0].strip() for v in value.elts]
    return []


def test_every_issue_package_is_in_the_workspace():
    assert {"imu_driver", "imu_calib", "wmra_filter", "ins_gps_kf", "imu_sim"} <= set(PACKAGES)


@pytest.mark.parametrize("pkg", PACKAGES)
def test_package_xml_is_format_3_ament_python_with_marker_and_setup_cfg(pkg):
    root = REPO / "src" / pkg
    package = parse_package(str(root / "package.xml"))
    assert package.package_format == 3 and package.name == pkg
    assert any(e.tagname == "build_type" and e.content == "ament_python" for e in package.exports)
    assert (root / "resource" / pkg).exists()
    cfg = (root / "setup.cfg").read_text()
    assert f"script_dir=$base/lib/{pkg}" in cfg and f"install_scripts=$base/lib/{pkg}" in cfg


def test_tf2_msgs_is_built_by_setup_never_by_colcon_and_is_jazzys_type():
    root = REPO / "src" / "tf2_msgs"
    package = parse_package(str(root / "package.xml"))
    assert package.name == "tf2_msgs" and (root / "COLCON_IGNORE").exists()  # a full install keeps its own
    assert (root / "msg" / "TFMessage.msg").read_text().split() == ["geometry_msgs/TransformStamped[]", "transforms"]
    description = Path(sys.prefix) / "share" / "tf2_msgs" / "msg" / "TFMessage.json"
    hashes = {h["type_name"]: h["hash_string"] for h in json.loads(description.read_text())["type_hashes"]}
    assert hashes["tf2_msgs/msg/TFMessage"] == TFMESSAGE_RIHS01
    from tf2_msgs.msg import TFMessage  # noqa: F401  (importable by the nodes)


@pytest.mark.slow
def test_colcon_build_installs_every_executable_under_lib_pkg(tmp_path):
    ws = tmp_path / "ws"
    ws.mkdir()
    (ws / "src").symlink_to(REPO / "src")
    colcon = Path(sys.executable).parent / "colcon"
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
    result = subprocess.run([str(colcon), "build", "--base-paths", "src", "--build-base", "build",
                             "--install-base", "install"], cwd=ws, env=env, capture_output=True, text=True,
                            timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr
    assert f"{len(PACKAGES)} packages finished" in result.stdout
    for pkg in PACKAGES:
        for exe in _console_scripts(pkg):
            path = ws / "install" / pkg / "lib" / pkg / exe
            assert path.exists() and os.access(path, os.X_OK), f"missing {path}"
    # An installed executable runs from the install space (what `ros2 run imu_driver bp3010_emulator` starts).
    site = ws / "install" / "imu_driver" / "lib" / f"python{sys.version_info.major}.{sys.version_info.minor}" / "site-packages"
    run = subprocess.run([str(ws / "install" / "imu_driver" / "lib" / "imu_driver" / "bp3010_emulator"), "--help"],
                         env=dict(env, PYTHONPATH=str(site)), capture_output=True, text=True, timeout=60)
    assert run.returncode == 0 and "pseudo-terminal" in run.stdout
