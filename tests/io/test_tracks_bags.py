"""ROS bag tracks: bags built with rosbags itself (rosbag2 sqlite3 and mcap, ROS 1), each
supported message type, the stamp and receive-time rule, and every malformed bag refused in one
line naming the bag."""

import sys
from pathlib import Path

import numpy as np
import pytest

from tether.errors import InvalidTrackError
from tether.io.tracks import read_track

pytest.importorskip("rosbags")

MSGTYPES = ["geometry_msgs/msg/PoseStamped", "geometry_msgs/msg/PointStamped",
            "geometry_msgs/msg/PoseWithCovarianceStamped", "nav_msgs/msg/Odometry"]


def _message(ts, msgtype: str, sec: int, nanosec: int, x: float, y: float, frame: str):
    m = ts.types
    extra = {"seq": 0} if "seq" in m["std_msgs/msg/Header"].__dataclass_fields__ else {}
    header = m["std_msgs/msg/Header"](
        stamp=m["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec), frame_id=frame,
        **extra)
    point = m["geometry_msgs/msg/Point"](x=x, y=y, z=0.0)
    quat = m["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
    pose = m["geometry_msgs/msg/Pose"](position=point, orientation=quat)
    import numpy as np

    if msgtype.endswith("PoseStamped"):
        return m[msgtype](header=header, pose=pose)
    if msgtype.endswith("PointStamped"):
        return m[msgtype](header=header, point=point)
    cov = m["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36))
    if msgtype.endswith("PoseWithCovarianceStamped"):
        return m[msgtype](header=header, pose=cov)
    twist = m["geometry_msgs/msg/TwistWithCovariance"](
        twist=m["geometry_msgs/msg/Twist"](
            linear=m["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
            angular=m["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)),
        covariance=np.zeros(36))
    return m[msgtype](header=header, child_frame_id="base_link", pose=cov, twist=twist)


def make_bag(path: Path, topics: dict, *, version: int = 2, storage: str = "sqlite3",
             frame: str = "map") -> Path:
    """Write a bag at ``path``: ``topics`` maps a topic to ``(msgtype, samples)`` with samples
    ``(stamp_s, receive_s, x, y)``; a stamp of 0 writes a zero header stamp."""
    from rosbags.typesys import Stores, get_typestore

    if version == 1:
        from rosbags.rosbag1 import Writer

        ts = get_typestore(Stores.ROS1_NOETIC)
        writer = Writer(path)
    else:
        from rosbags.rosbag2 import StoragePlugin, Writer

        ts = get_typestore(Stores.ROS2_HUMBLE)
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        writer = Writer(path, version=9, storage_plugin=plugin)
    with writer:
        for topic, (msgtype, samples) in topics.items():
            conn = writer.add_connection(topic, msgtype, typestore=ts)
            for stamp, receive, x, y in samples:
                sec, nanosec = int(stamp), int(round((stamp - int(stamp)) * 1e9))
                msg = _message(ts, msgtype, sec, nanosec, x, y, frame)
                data = (ts.serialize_ros1(msg, msgtype) if version == 1
                        else ts.serialize_cdr(msg, msgtype))
                writer.write(conn, int(round(receive * 1e9)), data)
    return path


SAMPLES = [(100.0, 100.5, 0.0, 0.0), (100.5, 101.0, 1.0, 0.0), (101.25, 101.5, 1.0, 2.0)]
VERSIONS = [(2, "sqlite3"), (2, "mcap"), (1, None)]


def _bag(tmp_path, version, storage, topics, **kw):
    name = f"v{version}{storage or ''}" + (".bag" if version == 1 else "")
    return make_bag(tmp_path / name, topics, version=version, storage=storage, **kw)


@pytest.mark.parametrize("version, storage, msgtype", [
    (2, "mcap", MSGTYPES[1]), (1, None, MSGTYPES[3])])
@pytest.mark.slow
def test_one_message_type_in_each_bag(tmp_path, version, storage, msgtype):
    test_every_message_type_in_every_bag(tmp_path, version, storage, msgtype)


@pytest.mark.slow
@pytest.mark.parametrize("version, storage", VERSIONS)
@pytest.mark.parametrize("msgtype", MSGTYPES)
def test_every_message_type_in_every_bag(tmp_path, version, storage, msgtype):
    bag = _bag(tmp_path, version, storage, {"/person": (msgtype, SAMPLES)}, frame="odom")
    tr = read_track(bag)
    assert tr.t.tolist() == [0.0, 0.5, 1.25]  # from the header stamps, from the first
    assert tr.xy.tolist() == [[0, 0], [1, 0], [1, 2]]
    assert tr.meta["t0"] == 100.0 and tr.meta["frame_id"] == "odom"
    assert tr.meta["topic"] == "/person" and tr.meta["msgtype"] == msgtype
    assert tr.meta["receive_time_samples"] == 0


@pytest.mark.slow
def test_a_zero_stamp_falls_back_to_the_receive_time(tmp_path):
    samples = [(100.0, 100.5, 0.0, 0.0), (0, 101.5, 1.0, 0.0), (102.0, 102.5, 2.0, 0.0)]
    bag = _bag(tmp_path, 2, "mcap", {"/p": (MSGTYPES[0], samples)})
    tr = read_track(bag)
    assert tr.t.tolist() == [0.0, 1.5, 2.0] and tr.meta["receive_time_samples"] == 1


def test_the_storage_file_names_its_bag(tmp_path):
    bag = _bag(tmp_path, 2, "mcap", {"/p": (MSGTYPES[1], SAMPLES)})
    (db,) = bag.glob("*.mcap")
    assert np.array_equal(read_track(db).xy, read_track(bag).xy)


def test_topic_choice(tmp_path):
    bag = _bag(tmp_path, 2, "mcap", {"/a": (MSGTYPES[0], SAMPLES),
                                        "/b": (MSGTYPES[3], SAMPLES[:2]),
                                        "/chatter": ("std_msgs/msg/String", [])})
    assert len(read_track(bag, topic="/b")) == 2
    with pytest.raises(InvalidTrackError, match="2 topics could be the track, choose one with "
                       "--topic: /a, /b"):
        read_track(bag)


def _string_bag(tmp_path):
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    path = tmp_path / "chatter"
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conn = w.add_connection("/chatter", "std_msgs/msg/String", typestore=ts)
        w.write(conn, 1, ts.serialize_cdr(ts.types["std_msgs/msg/String"](data="hi"),
                                          "std_msgs/msg/String"))
    return path


def _truncated(tmp_path):
    bag = _bag(tmp_path, 1, None, {"/p": (MSGTYPES[0], SAMPLES)})
    data = bag.read_bytes()
    bag.write_bytes(data[: len(data) // 2])
    return bag


def _garbage_db3(tmp_path):
    bag = _bag(tmp_path, 2, "sqlite3", {"/p": (MSGTYPES[0], SAMPLES)})
    (db,) = bag.glob("*.db3")
    db.write_bytes(b"not a database at all" * 10)
    return bag


BAD_BAGS = {
    "unknown topic": (lambda d: (_bag(d, 2, "mcap", {"/p": (MSGTYPES[0], SAMPLES)}), "/q"),
                      "no topic '/q' in the bag (topics: /p (geometry_msgs/msg/PoseStamped))"),
    "unsupported type": (lambda d: (_string_bag(d), "/chatter"),
                         "topic '/chatter' has type std_msgs/msg/String, not one of"),
    "no supported topic": (lambda d: (_string_bag(d), None),
                           "no topic of a supported type"),
    "no messages": (lambda d: (_bag(d, 1, None, {"/p": (MSGTYPES[2], [])}), None),
                    "topic '/p' has no messages"),
    "repeated stamp": (lambda d: (_bag(d, 2, "mcap", {"/p": (MSGTYPES[0], [
        (5.0, 5.0, 0, 0), (5.0, 5.1, 1, 0)])}), None),
                       "/p message 1: times must increase strictly"),
    "a folder, no bag": (lambda d: (d, None), "a folder that is not a ROS 2 bag (no "
                         "metadata.yaml)"),
    "missing bag": (lambda d: (d / "gone.bag", None), "no such bag"),
    "truncated ROS 1 bag": (lambda d: (_truncated(d), None), "cannot read the bag"),
    "corrupt rosbag2 storage": (lambda d: (_garbage_db3(d), None), "cannot read the bag"),
}


@pytest.mark.parametrize("case", [
    pytest.param(c, marks=pytest.mark.slow) if "rosbag2 storage" in c else c for c in BAD_BAGS])
def test_malformed_bags_one_line(tmp_path, case):
    make, words = BAD_BAGS[case]
    path, topic = make(tmp_path)
    with pytest.raises(InvalidTrackError) as err:
        read_track(path, topic=topic)
    msg = str(err.value)
    assert words in msg and "\n" not in msg
    assert msg.startswith(str(path))


def test_columns_do_not_apply_to_bags(tmp_path):
    bag = _bag(tmp_path, 1, None, {"/p": (MSGTYPES[0], SAMPLES)})
    with pytest.raises(InvalidTrackError, match="columns apply to CSV and JSON"):
        read_track(bag, columns=("t", "x", "y"))


@pytest.mark.slow
def test_without_rosbags_one_line(tmp_path, monkeypatch):
    bag = _bag(tmp_path, 1, None, {"/p": (MSGTYPES[0], SAMPLES)})
    monkeypatch.setitem(sys.modules, "rosbags.highlevel", None)
    with pytest.raises(InvalidTrackError, match=r"reading ROS bags needs `pip install "
                       r"tether\[bags\]`"):
        read_track(bag)
