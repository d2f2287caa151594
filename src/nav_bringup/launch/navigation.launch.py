"""The navigation graph on a full ROS 2 install: ``ros2 launch nav_bringup navigation.launch.py``.

The nodes, their per-run parameters and remaps are :func:`nav_bringup.description.navigation_graph`'s,
the description ``nav-demo`` (the process runner of pip-only installs) and the graph tests start
too, with the same params file (``config/navigation.yaml``); this file only turns it into actions.

    ros2 launch nav_bringup navigation.launch.py sim_dir:=/tmp/drive rate:=4.0
    ros2 launch nav_bringup navigation.launch.py recording:=/path/to/bag
    ros2 launch nav_bringup navigation.launch.py port:=/dev/ttyUSB0          # real hardware

``use_sim_time`` defaults to ``auto``: true when a simulation or a recording is played (the players
publish ``/clock``), false on real hardware, where no ``/clock`` exists. A simulation sets the
filter's datum to the scenario's, so ``map`` is the frame of ``truth/odometry``. The fusion node
publishes ``map -> odom -> base_link`` on ``/tf`` and the sensor mounts on ``/tf_static`` (REP-105);
the recorder records them with the rest.
"""
import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from nav_bringup.description import GraphInputs, navigation_graph, played_topics

ARGUMENTS = (
    ("sim_dir", "", "imu-sim output to play live"),
    ("recording", "", "rosbag2 bag to replay instead"),
    ("rate", "1.0", "playback speed"),
    ("port", "/tmp/bp3010", "serial port of the BP3010"),
    ("use_sim_time", "auto", "true, false, or auto: true when sim_dir or recording is played"),
    ("sensor_model", "", "sensor-model YAML (default: the package's config/sensor_models/bp3010.yaml)"),
    ("bag_out", "navigation_bag", "bag_record's output folder"),
)


def graph_inputs(values: dict, share: str) -> GraphInputs:
    """The description's inputs from the launch arguments (strings)."""
    source = "recording" if values["recording"] else "simulation" if values["sim_dir"] else "hardware"
    sim_time = {"true": True, "false": False}.get(values["use_sim_time"].lower())
    model = values["sensor_model"] or os.path.join(share, "config", "sensor_models", "bp3010.yaml")
    return GraphInputs(source, model, sim_dir=values["sim_dir"], recording=values["recording"],
                       port=values["port"], rate=float(values["rate"]), bag_out=values["bag_out"],
                       use_sim_time=sim_time,
                       played_topics=played_topics(values["recording"]) if values["recording"] else ())


def _nodes(context):
    share = get_package_share_directory("nav_bringup")
    params = os.path.join(share, "config", "navigation.yaml")
    values = {name: LaunchConfiguration(name).perform(context) for name, _, _ in ARGUMENTS}
    return [Node(package=spec.package, executable=spec.executable, arguments=list(spec.args),
                 parameters=[params, spec.overrides], remappings=list(spec.remaps))
            for spec in navigation_graph(graph_inputs(values, share))]


def generate_launch_description():
    """Driver (or scenario player / bag player) -> wmra_node -> ins_gps_kf_node, plus Allan node and recorder."""
    return LaunchDescription([DeclareLaunchArgument(name, default_value=default, description=text)
                              for name, default, text in ARGUMENTS] + [OpaqueFunction(function=_nodes)])
