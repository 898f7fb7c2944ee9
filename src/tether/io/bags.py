"""Person tracks from ROS bags, read with the ``rosbags`` library (optional extra
``tether[bags]``): rosbag2 (a folder with ``metadata.yaml``, sqlite3 or mcap storage) and ROS 1
``.bag`` files.

Message types (:data:`MESSAGE_TYPES`): ``geometry_msgs/PoseStamped``, ``PointStamped``,
``PoseWithCovarianceStamped`` and ``nav_msgs/Odometry``; the position's ``x`` and ``y`` make the
track, the header stamp its time.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from tether.errors import InvalidTrackError

__all__ = ["BAG_SUFFIXES", "MESSAGE_TYPES", "bag_samples"]

#: Suffixes read as bags: a ROS 1 bag, and a rosbag2's storage file (its folder is read).
BAG_SUFFIXES = (".bag", ".db3", ".mcap")


def _pose(msg: Any) -> tuple[float, float]:
    return msg.pose.position.x, msg.pose.position.y


def _point(msg: Any) -> tuple[float, float]:
    return msg.point.x, msg.point.y


def _pose_in_pose(msg: Any) -> tuple[float, float]:
    return msg.pose.pose.position.x, msg.pose.pose.position.y


#: The message types read, and how to take (x, y) from each (ROS 2 names; ROS 1's are the same
#: without ``/msg``).
MESSAGE_TYPES: dict[str, Callable[[Any], tuple[float, float]]] = {
    "geometry_msgs/msg/PoseStamped": _pose,
    "geometry_msgs/msg/PointStamped": _point,
    "geometry_msgs/msg/PoseWithCovarianceStamped": _pose_in_pose,
    "nav_msgs/msg/Odometry": _pose_in_pose,
}


def _reader(p: Path) -> Any:
    """An opened-to-be ``AnyReader`` for the bag at ``p`` (a rosbag2 folder for its storage
    file); one line when ``rosbags`` is missing or ``p`` is no bag."""
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise InvalidTrackError(f"{p}: reading ROS bags needs `pip install tether[bags]`") \
            from None
    if not p.exists():
        raise InvalidTrackError(f"{p}: no such bag")
    if p.suffix.lower() in (".db3", ".mcap"):
        p = p.parent
    if p.is_dir() and not (p / "metadata.yaml").is_file():
        raise InvalidTrackError(f"{p}: a folder that is not a ROS 2 bag (no metadata.yaml)")
    return AnyReader([p], default_typestore=get_typestore(Stores.ROS2_HUMBLE))


def _pick(p: Path, connections: list, topic: str | None) -> list:
    """The connections of ``topic`` (or of the one supported topic)."""
    types = {c.topic: c.msgtype for c in connections}
    listed = ", ".join(f"{t} ({m})" for t, m in sorted(types.items())) or "none"
    if topic is not None:
        if topic not in types:
            raise InvalidTrackError(f"{p}: no topic {topic!r} in the bag (topics: {listed})")
        if types[topic] not in MESSAGE_TYPES:
            raise InvalidTrackError(
                f"{p}: topic {topic!r} has type {types[topic]}, not one of "
                f"{', '.join(MESSAGE_TYPES)}")
        chosen = topic
    else:
        fit = sorted(t for t, m in types.items() if m in MESSAGE_TYPES)
        if not fit:
            raise InvalidTrackError(f"{p}: no topic of a supported type "
                                    f"({', '.join(MESSAGE_TYPES)}) in the bag (topics: {listed})")
        if len(fit) > 1:
            raise InvalidTrackError(f"{p}: {len(fit)} topics could be the track, choose one "
                                    f"with --topic: {', '.join(fit)}")
        chosen = fit[0]
    return [c for c in connections if c.topic == chosen]


def bag_samples(path: str | Path, *, topic: str | None = None
                ) -> tuple[np.ndarray, np.ndarray, str, dict]:
    """The timed positions of one topic of a ROS bag, as :func:`tether.io.tracks.read_track`
    makes a :class:`~tether.io.tracks.Track` of them.

    Parameters
    ----------
    path : str or Path
        A rosbag2 folder (``metadata.yaml`` and its ``.db3`` or ``.mcap`` storage), one of its
        storage files, or a ROS 1 ``.bag``.
    topic : str, optional
        The topic to read; by default the bag's one topic of a type in :data:`MESSAGE_TYPES`.

    Returns
    -------
    t, xy, name, meta
        Times (n,) in seconds from the first message (its absolute time, s since the epoch, is
        ``meta["t0"]``); positions are the messages' ``x, y`` as they are, in the frame
        ``meta["frame_id"]`` (the first message's header frame): transforming them into the
        map's frame is the user's. The time of a message is its header stamp; where the stamp
        is zero (an unstamped publisher) the bag's receive time is used instead, and
        ``meta["receive_time_samples"]`` counts how often.

    Raises
    ------
    InvalidTrackError
        One line naming the bag: ``rosbags`` missing (``pip install tether[bags]``), no bag,
        a truncated or unreadable bag, an unknown topic, a type not supported, several
        candidate topics and none chosen, no messages, times not increasing strictly.
    """
    p = Path(path)
    reader = _reader(p)
    try:
        with reader:
            conns = _pick(p, list(reader.connections), topic)
            msgtype = conns[0].msgtype
            take = MESSAGE_TYPES[msgtype]
            rows, frames, received = [], [], 0
            for conn, stamp_ns, raw in reader.messages(connections=conns):
                msg = reader.deserialize(raw, conn.msgtype)
                st = msg.header.stamp
                t_ns = int(st.sec) * 1_000_000_000 + int(st.nanosec)
                if t_ns == 0:
                    t_ns, received = int(stamp_ns), received + 1
                x, y = take(msg)
                rows.append((t_ns, float(x), float(y)))
                frames.append(msg.header.frame_id)
    except InvalidTrackError:
        raise
    except Exception as exc:  # noqa: BLE001 - rosbags raises many kinds on a broken bag
        raise InvalidTrackError(f"{p}: cannot read the bag ({type(exc).__name__}: "
                                f"{' '.join(str(exc).split()) or 'no detail'})") from None
    chosen = conns[0].topic
    if not rows:
        raise InvalidTrackError(f"{p}: topic {chosen!r} has no messages")
    ns = np.array([r[0] for r in rows], dtype=np.int64)
    xy = np.array([r[1:] for r in rows], dtype=float)
    if not np.all(np.isfinite(xy)):
        k = int(np.argmin(np.isfinite(xy).all(axis=1)))
        raise InvalidTrackError(f"{p}: {chosen} message {k}: position is not finite")
    step = np.diff(ns)
    if np.any(step <= 0):
        k = int(np.argmax(step <= 0)) + 1
        raise InvalidTrackError(
            f"{p}: {chosen} message {k}: times must increase strictly (stamp "
            f"{ns[k] / 1e9:.9f} s after {ns[k - 1] / 1e9:.9f} s)")
    meta = {"source": str(p), "topic": chosen, "msgtype": msgtype,
            "frame_id": frames[0], "t0": float(ns[0] / 1e9), "receive_time_samples": received}
    if len(set(frames)) > 1:
        meta["frame_ids"] = sorted(set(frames))
    return (ns - ns[0]) / 1e9, xy, p.stem if p.suffix else p.name, meta
