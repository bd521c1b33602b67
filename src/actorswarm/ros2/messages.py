"""Standard ROS 2 messages from the swarm's values, and back (common_interfaces only).

Positions are metres in the mission's ENU frame (x east, y north, z up), the frame every
:class:`~actorswarm.runtime.context.Vehicle` speaks; a heading is radians counter-clockwise
from east, the yaw of REP 103. Called on the loop's thread, with a node's message classes
imported on first use.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from actorswarm.ros2.load import Ros2Error, message_type

__all__ = [
    "POSE_TYPES",
    "diagnostics",
    "field",
    "navsat",
    "pose_of",
    "pose_stamped",
    "string",
    "yaw_of",
]

#: The pose messages a vehicle or a plugin may read a position from.
POSE_TYPES = (
    "geometry_msgs/msg/PoseStamped",
    "nav_msgs/msg/Odometry",
    "geometry_msgs/msg/PoseWithCovarianceStamped",
)


def pose_stamped(
    stamp: Any, frame: str, position: Sequence[float], yaw: float | None = None
) -> Any:
    """A ``geometry_msgs/PoseStamped`` at ``position`` facing ``yaw`` (None: identity)."""
    msg = message_type("geometry_msgs/msg/PoseStamped")()
    msg.header.stamp = stamp
    msg.header.frame_id = frame
    p = msg.pose.position
    p.x, p.y, p.z = (float(v) for v in (*position, 0.0, 0.0, 0.0)[:3])
    if yaw is not None and math.isfinite(yaw):
        msg.pose.orientation.z = math.sin(yaw / 2)
        msg.pose.orientation.w = math.cos(yaw / 2)
    else:
        msg.pose.orientation.w = 1.0
    return msg


def pose_of(message: Any) -> tuple[float, float, float]:
    """The position in a PoseStamped, an Odometry or a PoseWithCovarianceStamped."""
    pose = message.pose
    inner = getattr(pose, "pose", None)  # Odometry and PoseWithCovarianceStamped nest it
    position = (inner if inner is not None else pose).position
    return float(position.x), float(position.y), float(position.z)


def yaw_of(message: Any) -> float:
    """The yaw (radians, counter-clockwise from x) of a pose message's orientation."""
    pose = message.pose
    inner = getattr(pose, "pose", None)
    q = (inner if inner is not None else pose).orientation
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


def navsat(stamp: Any, frame: str, lat: float, lon: float, alt: float) -> Any:
    """A ``sensor_msgs/NavSatFix`` (covariance unknown) at a geodetic position."""
    msg = message_type("sensor_msgs/msg/NavSatFix")()
    msg.header.stamp = stamp
    msg.header.frame_id = frame
    msg.latitude, msg.longitude, msg.altitude = float(lat), float(lon), float(alt)
    msg.status.status = 0  # STATUS_FIX
    msg.position_covariance_type = 0  # COVARIANCE_TYPE_UNKNOWN
    return msg


def string(text: str) -> Any:
    msg = message_type("std_msgs/msg/String")()
    msg.data = text
    return msg


def diagnostics(stamp: Any, name: str, values: Mapping[str, object], alarm: bool) -> Any:
    """A ``diagnostic_msgs/DiagnosticArray`` of one status ``name`` whose key/values are
    ``values`` (the vehicle's status entries), level ERROR when ``alarm``, else OK."""
    array = message_type("diagnostic_msgs/msg/DiagnosticArray")()
    status_cls = message_type("diagnostic_msgs/msg/DiagnosticStatus")
    pair = message_type("diagnostic_msgs/msg/KeyValue")
    array.header.stamp = stamp
    status = status_cls()
    status.level = status_cls.ERROR if alarm else status_cls.OK
    status.name = name
    status.hardware_id = name
    status.message = "alarm" if alarm else "ok"
    status.values = [pair(key=str(k), value=str(v)) for k, v in values.items()]
    array.status = [status]
    return array


def field(message: Any, path: str) -> Any:
    """The value at ``path`` in ``message``: dotted field names and list indices
    (``detections.0.results.0.hypothesis.class_id``). :class:`Ros2Error` naming the part
    that is not there."""
    value = message
    for part in path.split("."):
        try:
            value = value[int(part)] if part.lstrip("-").isdigit() else getattr(value, part)
        except (AttributeError, IndexError, TypeError, KeyError):
            fields = _fields(message)
            known = f": {type(message).__name__} has {', '.join(fields)}" if fields else ""
            raise Ros2Error(f"the message has no field {path!r} (at {part!r}){known}") from None
    return value


def _fields(message: Any) -> list[str]:
    names = getattr(message, "get_fields_and_field_types", None)
    return list(names()) if callable(names) else []
