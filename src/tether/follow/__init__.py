"""A follower for a real robot's loop: keep the target in view at the rod length, and when it is
lost, search where it can have gone (``docs/practice.md``).

:class:`Follower` (:mod:`~tether.follow.follower`) takes one observation per update (the
target's position or ``None``, possibly noisy and late) and returns a :class:`Command` (goal
pose, velocity, status). :mod:`~tether.follow.reachable` holds the line of sight, the exact
geodesic distances and the reachable set's grid; :mod:`~tether.follow.search` the candidate
poses and their scores; :mod:`~tether.follow.baseline` a Nav2-like follower that spins in place
when the target is lost; :mod:`~tether.follow.replay` runs either on a recorded track with the
target observed only while in view. Nothing here depends on ROS (``examples/ros2_follower_node.py``
wraps the follower in a ROS 2 node).
"""

from __future__ import annotations

from tether.follow.follower import Command, Follower, Status

__all__ = ["Command", "Follower", "Status"]
