"""The navigation graph on a full ROS 2 install: ``ros2 launch nav_bringup navigation.launch.py``.

Same nodes and the same params file (``config/navigation.yaml``) as the process
runner that pip-only installs use (``nav-demo``, ``nav_bringup.graph``).

    ros2 launch nav_bringup navigation.launch.py sim_dir:=/tmp/drive rate:=4.0
    ros2 launch nav_bringup navigation.launch.py recording:=/path/to/bag
    ros2 launch nav_bringup navigation.launch.py port:=/dev/ttyUSB0          # real hardware

``use_sim_time`` defaults to ``auto``: true when a simulation or a recording is played (the players
publish ``/clock``), false on real hardware, where no ``/clock`` exists. The fusion node publishes
``map -> odom -> base_link`` on ``/tf`` and the sensor mounts on ``/tf_static`` (REP-105); the
recorder records them with the rest.
"""
import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition, UnlessCondition
from launch.substitutions import LaunchConfiguration, PythonExpression
from launch_ros.actions import Node


def generate_launch_description():
    """Driver (or scenario player / bag player) -> wmra_node -> ins_gps_kf_node, plus Allan node and recorder."""
    share = get_package_share_directory("nav_bringup")
    params = os.path.join(share, "config", "navigation.yaml")
    model = os.path.join(share, "config", "sensor_models", "bp3010.yaml")
    arg = LaunchConfiguration
    played = ["('", arg("recording"), "' != '' or '", arg("sim_dir"), "' != '')"]
    sim = {"use_sim_time": PythonExpression(["'", arg("use_sim_time"), "' == 'true' or ('", arg("use_sim_time"),
                                             "' == 'auto' and ", *played, ")"])}
    live = PythonExpression(["'", arg("recording"), "' == ''"])
    simulated = PythonExpression(["'", arg("recording"), "' == '' and '", arg("sim_dir"), "' != ''"])
    return LaunchDescription([
        DeclareLaunchArgument("sim_dir", default_value="", description="imu-sim output to play live"),
        DeclareLaunchArgument("recording", default_value="", description="rosbag2 bag to replay instead"),
        DeclareLaunchArgument("rate", default_value="1.0", description="playback speed"),
        DeclareLaunchArgument("port", default_value="/tmp/bp3010", description="serial port of the BP3010"),
        DeclareLaunchArgument("use_sim_time", default_value="auto",
                              description="true, false, or auto: true when sim_dir or recording is played"),
        DeclareLaunchArgument("sensor_model", default_value=model),
        DeclareLaunchArgument("bag_out", default_value="navigation_bag"),
        Node(package="nav_bringup", executable="scenario_player", parameters=[
            params, {"sim_dir": arg("sim_dir"), "rate": arg("rate"), "link": arg("port")}],
            condition=IfCondition(simulated)),
        # as nav-demo: the topics the graph reads, once the node reading each and the recorder subscribe, then
        # a settle (a node subscribed before the player counts its publisher up to ~2.5 s after it is counted)
        Node(package="imu_driver", executable="bag_play", parameters=[
            params, {"bag": arg("recording"), "rate": arg("rate"), "topics": ["imu/data_raw", "gps/fix"],
                     "wait_for_subscribers": 2, "settle_s": 3.0}], condition=UnlessCondition(live)),
        Node(package="imu_driver", executable="bp3010_driver", parameters=[params, sim, {"port": arg("port")}],
             condition=IfCondition(live)),
        Node(package="wmra_filter", executable="wmra_node",
             parameters=[params, sim, {"sensor_model_path": arg("sensor_model")}]),
        Node(package="ins_gps_kf", executable="ins_gps_kf_node",
             parameters=[params, sim, {"sensor_model_path": arg("sensor_model")}]),
        Node(package="imu_calib", executable="allan_node", parameters=[params, sim]),
        Node(package="imu_driver", executable="bag_record", parameters=[params, sim, {"output": arg("bag_out")}]),
    ])
