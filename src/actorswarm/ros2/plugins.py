"""The built-in ROS 2 plugins, registered as entry points (they need a daemon with a ROS 2
node: ``actorswarm daemon --ros2``).

``ros2.topic_event`` (:class:`TopicEvent`)
    Emits ``event`` when a message on ``topic`` passes a filter: a perception node's
    detection becomes ``target_detected_event``. The filter compares one ``field`` of the
    message (a dotted path, list indices as numbers: ``detections.0.results.0.hypothesis.
    class_id``) with ``value`` by ``op`` (``eq``, ``ne``, ``lt``, ``le``, ``gt``, ``ge``,
    ``contains``; ``any``, the default: every message passes). ``value`` is read as the
    field's type (a number for a number, ``true``/``false`` for a bool). At most one event
    per ``cooldown`` seconds. A message without the field is reported once (the daemon's
    ``ros2-error`` line, naming the topic), not raised.
``ros2.publish_state``
    Publishes the platform's pose (``geometry_msgs/PoseStamped`` in the mission's ENU frame
    ``frame``, when it has a vehicle) on ``pose`` and the actor it runs in
    (``std_msgs/String``, latched) on ``actor``, ``rate`` times a second — by default under
    the platform's namespace, ``/<swarm>/p<N>/pose`` and ``/<swarm>/p<N>/actor``, the names
    the ground bridge uses.
"""

from __future__ import annotations

import operator
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, ClassVar, Final

from actorswarm.ros2 import messages as msgs
from actorswarm.ros2.load import Ros2Error
from actorswarm.runtime.builtin import EVENT_NAME_FORM, EVENT_NAME_PATTERN
from actorswarm.runtime.plugin import Param, Plugin

if TYPE_CHECKING:
    from actorswarm.ros2.platform import PlatformRos, Reader
    from actorswarm.runtime.context import PluginContext

__all__ = ["PublishState", "TopicEvent", "matches"]

_OPS: Final[dict[str, Callable[[Any, Any], bool]]] = {
    "eq": operator.eq,
    "ne": operator.ne,
    "lt": operator.lt,
    "le": operator.le,
    "gt": operator.gt,
    "ge": operator.ge,
    "contains": lambda field, value: value in field,
}
_QOS = ("reliable", "sensor", "latched")


def ros_of(ctx: PluginContext) -> PlatformRos:
    """``ctx.ros2``, or an error saying the daemon needs ``--ros2``."""
    ros = ctx.ros2
    if ros is None:
        raise Ros2Error(
            f"actor {ctx.actor!r} on platform {ctx.platform}: this plugin needs ROS 2 and "
            "the platform has no ROS 2 node (start its daemon with --ros2, or [ros2] in its "
            "configuration)"
        )
    return ros  # type: ignore[no-any-return]


def _as(kind: Any, text: str) -> Any:
    if isinstance(kind, bool):
        return text.strip().lower() in ("true", "yes", "on", "1")
    if isinstance(kind, int | float):
        return type(kind)(float(text)) if isinstance(kind, float) else int(float(text))
    if isinstance(kind, bytes):  # a byte field (uint8 in some rclpy versions)
        return bytes([int(text)])
    return text


def matches(message: Any, field: str, op: str, value: str) -> bool:
    """Whether ``message`` passes the filter (see the module docstring);
    :class:`~actorswarm.ros2.load.Ros2Error` when the field is not there, ValueError when
    ``value`` does not read as the field's type."""
    if op == "any":
        return True
    got = msgs.field(message, field)
    if op == "contains":
        return value in (got if isinstance(got, str) else [str(v) for v in got])
    return bool(_OPS[op](got, _as(got, value)))


class TopicEvent(Plugin):
    """``ros2.topic_event``: a ROS 2 message that passes a filter raises a task event."""

    any_bus = True
    params: ClassVar[Mapping[str, Param]] = {
        "topic": Param(kind="str", required=True, doc="the topic (relative: under /SWARM/pN/)"),
        "type": Param(kind="str", required=True, doc="its message type, e.g. std_msgs/msg/String"),
        "event": Param(
            kind="str",
            required=True,
            pattern=EVENT_NAME_PATTERN,
            form=EVENT_NAME_FORM,
            doc="the event to emit",
        ),
        "scope": Param(kind="str", default="local", choices=("local", "swarm")),
        "field": Param(kind="str", default=None, doc="the field compared (dotted path)"),
        "op": Param(kind="str", default="any", choices=("any", *_OPS)),
        "value": Param(kind="str", default=None, doc="what the field is compared with"),
        "qos": Param(kind="str", default="reliable", choices=_QOS),
        "cooldown": Param(kind="float", default=1.0, minimum=0.0, doc="seconds between events"),
    }

    def __init__(self) -> None:
        self._reader: Reader | None = None
        self._last = -1e18
        self._reported = False

    def on_start(self, ctx: PluginContext) -> None:
        p = ctx.params
        if p["op"] != "any" and (p["field"] is None or p["value"] is None):
            raise ValueError(f"ros2.topic_event: op {p['op']!r} needs a field and a value")
        self._reader = ros_of(ctx).subscribe(p["topic"], p["type"], qos=p["qos"])

    def step(self, ctx: PluginContext) -> None:
        if self._reader is None:
            return
        p = ctx.params
        for message in self._reader.take():
            try:
                passed = matches(message, p["field"] or "", p["op"], p["value"] or "")
            except (Ros2Error, ValueError, TypeError) as exc:
                if not self._reported:
                    self._reported = True
                    ros_of(ctx).report(f"topic {self._reader.topic}: filter: {exc}")
                continue
            if passed and ctx.now - self._last >= p["cooldown"]:
                self._last = ctx.now
                ctx.emit(p["event"], scope=p["scope"])

    def next_deadline(self) -> float | None:
        """Due at once while messages wait: the runtime steps the actor at the wake that
        brought them instead of at its next 10 Hz step."""
        return 0.0 if self._reader is not None and self._reader.waiting else None  # past


class PublishState(Plugin):
    """``ros2.publish_state``: the platform's pose and actor, published onboard."""

    any_bus = True
    params: ClassVar[Mapping[str, Param]] = {
        "pose": Param(kind="str", default="pose", doc="the pose topic"),
        "actor": Param(kind="str", default="actor", doc="the actor topic"),
        "frame": Param(kind="str", default="map", doc="the mission's ENU frame id"),
        "rate": Param(kind="float", default=5.0, minimum=0.1, doc="publications per second"),
    }

    def __init__(self) -> None:
        self._next = 0.0

    def on_start(self, ctx: PluginContext) -> None:
        ros = ros_of(ctx)
        ros.publish(
            ctx.params["actor"], "std_msgs/msg/String", msgs.string(ctx.actor), qos="latched"
        )
        self._next = ctx.now

    def step(self, ctx: PluginContext) -> None:
        if ctx.now < self._next:
            return
        self._next = ctx.now + 1.0 / ctx.params["rate"]
        if ctx.vehicle is not None:
            ros = ros_of(ctx)
            pose = msgs.pose_stamped(ros.stamp(), ctx.params["frame"], ctx.vehicle.position())
            ros.publish(ctx.params["pose"], "geometry_msgs/msg/PoseStamped", pose)

    def next_deadline(self) -> float | None:
        return self._next
