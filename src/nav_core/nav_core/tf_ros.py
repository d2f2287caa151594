"""ROS glue of :mod:`nav_core.tf_tree`: ``/tf`` and ``/tf_static`` publishers (a tf2_ros broadcaster stand-in).

tf2_ros is not on PyPI; ``tf2_msgs`` is built from its message definition by ``scripts/setup_env.sh``
(on a full ROS 2 install the system package is used). The QoS are tf2_ros's: ``/tf`` reliable,
volatile, depth 100; ``/tf_static`` reliable, transient local, depth 1, so every static transform
goes out in one message that late subscribers still receive.
"""
from __future__ import annotations

from geometry_msgs.msg import TransformStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from tf2_msgs.msg import TFMessage

from nav_core.ros_node import stamp_from_s
from nav_core.tf_tree import Pose

TF_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
TF_STATIC_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                           durability=DurabilityPolicy.TRANSIENT_LOCAL)


def transform_stamped(stamp, parent: str, child: str, pose: Pose) -> TransformStamped:
    """A ``TransformStamped`` parent -> child (``stamp`` a builtin_interfaces/Time)."""
    msg = TransformStamped()
    msg.header.stamp = stamp
    msg.header.frame_id = parent
    msg.child_frame_id = child
    tr, q = msg.transform.translation, msg.transform.rotation
    tr.x, tr.y, tr.z = (float(v) for v in pose.position)
    q.x, q.y, q.z, q.w = (float(v) for v in pose.quat_xyzw)
    return msg


class TfBroadcaster:
    """Publishes transforms on ``/tf`` and, once (latched), the static ones on ``/tf_static``."""

    def __init__(self, node: Node):
        self._node = node
        self._pub = node.create_publisher(TFMessage, "/tf", TF_QOS)
        self._static_pub = None

    def send(self, t_s: float, transforms) -> None:
        """Publish ``(parent, child, Pose)`` transforms stamped ``t_s`` s on /tf, in one message."""
        stamp = stamp_from_s(t_s)
        self._pub.publish(TFMessage(transforms=[transform_stamped(stamp, *tr) for tr in transforms]))

    def send_static(self, transforms) -> None:
        """Publish ``(parent, child, Pose)`` static transforms on /tf_static (all of them: the topic keeps one)."""
        if self._static_pub is None:
            self._static_pub = self._node.create_publisher(TFMessage, "/tf_static", TF_STATIC_QOS)
        stamp = self._node.get_clock().now().to_msg()
        self._static_pub.publish(TFMessage(transforms=[transform_stamped(stamp, *tr) for tr in transforms]))
