r"""A ROS 2 node around :class:`tether.Follower`: person in, velocity and goal out.

Subscribes:

* ``person`` (``geometry_msgs/PointStamped`` or, with ``person_type:=pose``,
  ``geometry_msgs/PoseStamped``): the detected person, **in the map's frame** (``frame_id``
  parameter, default ``map``; a message in another frame is dropped with a warning: transform
  it first, e.g. with ``tf2_ros``). Its header stamp is the observation's time (late
  observations are handled by the follower). No message for ``timeout`` s means "not seen".
* ``odom`` (``nav_msgs/Odometry``): the robot's pose in the same frame.

Publishes, every ``1/rate`` s:

* ``cmd_vel`` (``geometry_msgs/Twist``): the follower's velocity in the robot's frame (a
  holonomic base: ``linear.x``, ``linear.y``) and a turn toward the goal heading
  (``angular.z = heading_gain · heading error``, at most ``max_turn`` rad/s);
* ``goal_pose`` (``geometry_msgs/PoseStamped``): the goal pose, for a navigation stack that
  plans its own way (Nav2's ``NavigateToPose``);
* ``follower_status`` (``std_msgs/String``): ``tracking``, ``searching`` or ``lost: reason``.

Parameters: ``map`` (a map file tether reads: ``.yaml`` of ``map_server``, ``.json``, ...),
``lss``, ``vt``, ``vo`` (map units and map units/s), ``rate`` (Hz), ``noise``, ``range``
(0: unlimited), ``timeout``, ``frame_id``, ``person_type`` (``point`` or ``pose``),
``heading_gain``, ``max_turn``.

Run (with tether installed in the ROS 2 Python environment)::

    python3 ros2_follower_node.py --ros-args -p map:=office.yaml -p lss:=0.8 \
        -p vt:=0.3 -p vo:=1.0 -r person:=/people/closest -r odom:=/odom

The node is an example of wiring, not part of the package (tether has no ROS dependency);
``tests/follow/test_ros2_example.py`` runs it against a fake ``rclpy``.
"""

from __future__ import annotations

import math

import rclpy
from geometry_msgs.msg import PointStamped, PoseStamped, Twist
from nav_msgs.msg import Odometry
from rclpy.node import Node
from std_msgs.msg import String

from tether import Follower, load_map

__all__ = ["FollowerNode", "main"]

DEFAULTS = {"map": "", "lss": 1.0, "vt": 0.3, "vo": 1.0, "rate": 20.0, "noise": 0.0,
            "range": 0.0, "timeout": 0.3, "frame_id": "map", "person_type": "point",
            "heading_gain": 1.5, "max_turn": 1.5}


def _seconds(stamp) -> float:
    return float(stamp.sec) + 1e-9 * float(stamp.nanosec)


def _yaw(q) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


class FollowerNode(Node):
    """The node (see the module docstring)."""

    def __init__(self) -> None:
        super().__init__("tether_follower")
        p = {k: self.declare_parameter(k, v).value for k, v in DEFAULTS.items()}
        if not p["map"]:
            raise ValueError("parameter 'map' is required (a map file tether reads)")
        self.params = p
        self.follower = Follower(load_map(p["map"]), p["lss"], p["vt"], p["vo"],
                                 rate=p["rate"], noise=p["noise"],
                                 sensor_range=p["range"] or None)
        kind = PoseStamped if p["person_type"] == "pose" else PointStamped
        self.create_subscription(kind, "person", self.on_person, 10)
        self.create_subscription(Odometry, "odom", self.on_odom, 10)
        self.cmd_pub = self.create_publisher(Twist, "cmd_vel", 10)
        self.goal_pub = self.create_publisher(PoseStamped, "goal_pose", 10)
        self.status_pub = self.create_publisher(String, "follower_status", 10)
        self.person: tuple[float, float, float] | None = None  # (x, y, stamp s)
        self.used_stamp = -math.inf
        self.robot: tuple[float, float, float] | None = None  # (x, y, yaw)
        self.create_timer(1.0 / p["rate"], self.tick)

    def on_person(self, msg) -> None:
        """Keep the latest detection (in the map's frame)."""
        if msg.header.frame_id != self.params["frame_id"]:
            self.get_logger().warn(f"person in frame '{msg.header.frame_id}', expected "
                                   f"'{self.params['frame_id']}': dropped")
            return
        pt = msg.pose.position if hasattr(msg, "pose") else msg.point
        self.person = (float(pt.x), float(pt.y), _seconds(msg.header.stamp))

    def on_odom(self, msg) -> None:
        """Keep the robot's pose."""
        pose = msg.pose.pose
        self.robot = (float(pose.position.x), float(pose.position.y), _yaw(pose.orientation))

    def tick(self) -> None:
        """One update of the follower; publish its command."""
        now = self.get_clock().now().nanoseconds * 1e-9
        obs = stamp = None
        if self.person is not None:
            x, y, s = self.person
            if s > self.used_stamp and now - s <= self.params["timeout"]:
                obs, stamp = (x, y), min(s, now)
                self.used_stamp = s
        observer = None if self.robot is None else self.robot[:2]
        cmd = self.follower.update(now, obs, stamp, observer=observer)
        self.publish(cmd, now)

    def publish(self, cmd, now: float) -> None:
        """The command as Twist (robot frame), goal PoseStamped and status String."""
        yaw = 0.0 if self.robot is None else self.robot[2]
        c, s = math.cos(yaw), math.sin(yaw)
        vx, vy = float(cmd.velocity[0]), float(cmd.velocity[1])
        twist = Twist()
        twist.linear.x, twist.linear.y = c * vx + s * vy, -s * vx + c * vy
        heading = cmd.pose[2]
        if math.isfinite(heading) and str(cmd.status) != "lost":
            err = (heading - yaw + math.pi) % (2 * math.pi) - math.pi
            turn = self.params["heading_gain"] * err
            twist.angular.z = max(-self.params["max_turn"], min(self.params["max_turn"], turn))
        self.cmd_pub.publish(twist)
        if math.isfinite(cmd.pose[0]):
            goal = PoseStamped()
            goal.header.frame_id = self.params["frame_id"]
            goal.header.stamp.sec = int(now)
            goal.header.stamp.nanosec = int((now - int(now)) * 1e9)
            goal.pose.position.x, goal.pose.position.y = cmd.pose[0], cmd.pose[1]
            half = 0.5 * (heading if math.isfinite(heading) else 0.0)
            goal.pose.orientation.z, goal.pose.orientation.w = math.sin(half), math.cos(half)
            self.goal_pub.publish(goal)
        status = String()
        status.data = str(cmd.status) + (f": {cmd.reason}" if cmd.reason else "")
        self.status_pub.publish(status)


def main(args=None) -> None:
    """Spin the node until shutdown."""
    rclpy.init(args=args)
    node = FollowerNode()
    try:
        rclpy.spin(node)
    finally:
        node.destroy_node()
        rclpy.shutdown()


if __name__ == "__main__":
    main()
