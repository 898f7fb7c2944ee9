"""``ros2_example/ros2_follower_node.py`` against a fake ``rclpy``: small stand-in modules
(``rclpy``, ``rclpy.node``, ``geometry_msgs.msg``, ``nav_msgs.msg``, ``std_msgs.msg``) put in
``sys.modules``, a clock the test sets, and callbacks the test calls as ROS would."""

from __future__ import annotations

import importlib.util
import math
import sys
import types
from pathlib import Path

import pytest

from tether.io import save_map

NODE = Path(__file__).resolve().parents[2] / "ros2_example" / "ros2_follower_node.py"


class _Msg:
    """A message: only the fields its type declares (as ROS messages: ``hasattr`` tells the
    types apart)."""


def _message(name, fields):
    def init(self):
        for f, default in fields.items():
            object.__setattr__(self, f, default() if callable(default) else default)
    return type(name, (_Msg,), {"__init__": init})


def _header():
    h = _Msg()
    h.frame_id = ""
    h.stamp = _Msg()
    h.stamp.sec, h.stamp.nanosec = 0, 0
    return h


def _vec():
    v = _Msg()
    v.x = v.y = v.z = 0.0
    return v


def _quat():
    q = _vec()
    q.w = 1.0
    return q


def _pose():
    p = _Msg()
    p.position, p.orientation = _vec(), _quat()
    return p


class _Param:
    def __init__(self, value):
        self.value = value


class _Publisher:
    def __init__(self):
        self.sent = []

    def publish(self, msg):
        self.sent.append(msg)


class FakeNode:
    """The parts of ``rclpy.node.Node`` the example uses."""

    overrides: dict = {}
    now = 0.0
    instances: list = []

    def __init__(self, name):
        self.name = name
        self.subs, self.pubs, self.timers, self.warnings = {}, {}, [], []
        FakeNode.instances.append(self)

    def declare_parameter(self, name, default):
        return _Param(self.overrides.get(name, default))

    def create_subscription(self, kind, topic, callback, qos):
        self.subs[topic] = (kind, callback)

    def create_publisher(self, kind, topic, qos):
        self.pubs[topic] = _Publisher()
        return self.pubs[topic]

    def create_timer(self, period, callback):
        self.timers.append((period, callback))

    def get_clock(self):
        clock = types.SimpleNamespace()
        clock.now = lambda: types.SimpleNamespace(nanoseconds=int(FakeNode.now * 1e9))
        return clock

    def get_logger(self):
        return types.SimpleNamespace(warn=self.warnings.append, info=lambda m: None)

    def destroy_node(self):
        pass


@pytest.fixture
def node_module(monkeypatch):
    rclpy = types.ModuleType("rclpy")
    rclpy.init = lambda args=None: None
    rclpy.spin = lambda node: None
    rclpy.shutdown = lambda: None
    rnode = types.ModuleType("rclpy.node")
    rnode.Node = FakeNode
    rclpy.node = rnode
    geo = types.ModuleType("geometry_msgs.msg")
    geo.PointStamped = _message("PointStamped", {"header": _header, "point": _vec})
    geo.PoseStamped = _message("PoseStamped", {"header": _header, "pose": _pose})
    geo.Twist = _message("Twist", {"linear": _vec, "angular": _vec})
    nav = types.ModuleType("nav_msgs.msg")
    nav.Odometry = _message("Odometry", {"header": _header, "pose": lambda: _with_pose()})
    std = types.ModuleType("std_msgs.msg")
    std.String = _message("String", {"data": ""})
    for name, mod in {"rclpy": rclpy, "rclpy.node": rnode, "geometry_msgs": types.ModuleType(
            "geometry_msgs"), "geometry_msgs.msg": geo, "nav_msgs": types.ModuleType("nav_msgs"),
            "nav_msgs.msg": nav, "std_msgs": types.ModuleType("std_msgs"),
            "std_msgs.msg": std}.items():
        monkeypatch.setitem(sys.modules, name, mod)
    spec = importlib.util.spec_from_file_location("ros2_follower_node", NODE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    FakeNode.instances = []
    return module, geo, nav


def _with_pose():
    p = _Msg()
    p.pose = _pose()
    return p


def _point(geo, x, y, t, frame="map"):
    msg = geo.PointStamped()
    msg.header.frame_id = frame
    msg.header.stamp.sec, msg.header.stamp.nanosec = int(t), int(round((t - int(t)) * 1e9))
    msg.point.x, msg.point.y = x, y
    return msg


def _odom(nav, x, y, yaw):
    msg = nav.Odometry()
    msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
    msg.pose.pose.orientation.z = math.sin(yaw / 2)
    msg.pose.pose.orientation.w = math.cos(yaw / 2)
    return msg


def test_node_tracks_then_searches(node_module, tmp_path, corridor):
    module, geo, nav = node_module
    path = tmp_path / "corridor.json"
    save_map(corridor, path)
    FakeNode.overrides = {"map": str(path), "lss": 1.0, "vt": 0.5, "vo": 1.0, "rate": 10.0}
    node = module.FollowerNode()
    assert set(node.subs) == {"person", "odom"} and node.timers[0][0] == pytest.approx(0.1)
    tick = node.timers[0][1]
    on_person, on_odom = node.subs["person"][1], node.subs["odom"][1]
    status = node.pubs["follower_status"].sent
    FakeNode.now = 10.0
    tick()
    assert status[-1].data.startswith("lost: no sighting")
    on_odom(_odom(nav, 2.0, 0.5, math.pi / 2))  # robot facing +y
    for k in range(5):
        FakeNode.now = 10.0 + 0.1 * k
        on_person(_point(geo, 1.0 + 0.05 * k, 0.5, FakeNode.now - 0.05))  # 50 ms late
        tick()
    assert status[-1].data.startswith("tracking")
    twist = node.pubs["cmd_vel"].sent[-1]
    # the person walks +x at 0.5: in the robot's frame (yaw 90°) that is -y
    assert math.hypot(twist.linear.x, twist.linear.y) <= 1.0 + 1e-9
    assert twist.linear.y < 0
    goal = node.pubs["goal_pose"].sent[-1]
    assert goal.header.frame_id == "map" and goal.pose.position.x > 1.5
    FakeNode.now = 11.0  # no fresh detection for 0.6 s: not seen; the robot sees the whole
    on_odom(_odom(nav, 0.5, 0.5, 0.0))  # arm the person can have reached: they are gone
    tick()
    assert status[-1].data.startswith("lost: the whole reachable set was seen")
    twist = node.pubs["cmd_vel"].sent[-1]
    assert (twist.linear.x, twist.linear.y, twist.angular.z) == (0.0, 0.0, 0.0)


def test_node_drops_other_frames_and_needs_a_map(node_module, tmp_path, corridor):
    module, geo, _ = node_module
    FakeNode.overrides = {}
    with pytest.raises(ValueError, match="map"):
        module.FollowerNode()
    path = tmp_path / "corridor.json"
    save_map(corridor, path)
    FakeNode.overrides = {"map": str(path), "rate": 10.0}
    node = module.FollowerNode()
    node.subs["person"][1](_point(geo, 1.0, 0.5, 0.0, frame="base_link"))
    assert node.person is None and "base_link" in node.warnings[0]


def test_main_spins_and_shuts_down(node_module, tmp_path, corridor):
    module, _, _ = node_module
    path = tmp_path / "corridor.json"
    save_map(corridor, path)
    FakeNode.overrides = {"map": str(path)}
    module.main()
    assert len(FakeNode.instances) == 1
