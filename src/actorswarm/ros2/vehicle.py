"""``--vehicle ros2``: a :class:`~actorswarm.runtime.context.Vehicle` over ROS 2 topics.

For a robot whose autopilot or simulator already speaks ROS 2: its pose comes in
(``geometry_msgs/PoseStamped``, ``nav_msgs/Odometry`` or
``geometry_msgs/PoseWithCovarianceStamped``), position setpoints go out
(``geometry_msgs/PoseStamped``, streamed at ``rate`` Hz from the node's thread, as offboard
controllers want), and take-off and landing are ``std_srvs/Trigger`` services when the
robot has them. Topic names are configurable; ``{platform}`` in a name is replaced by the
platform's ID. :data:`PROFILES` holds the names of the common stacks:

``generic``
    ``robot/pose`` in, ``robot/setpoint`` out, under the daemon's namespace
    ``/<swarm>/p<N>/`` (the robot's own node in ``/<swarm>/p<N>/robot``).
``aerostack2``
    ``/drone{platform}/self_localization/pose`` in (sensor QoS), ``/drone{platform}/
    motion_reference/pose`` out, frame ``earth``. Aerostack2's take-off and landing are
    actions of as2_msgs, not on PyPI: take off by a setpoint (its motion controller must be
    in position mode) or give the Trigger services of a wrapper.
``mavros``
    ``/mavros/local_position/pose`` in (sensor QoS), ``/mavros/setpoint_position/local`` out
    (ENU, frame ``map``). Arming and OFFBOARD/GUIDED mode stay with MAVROS's own services
    (mavros_msgs, not on PyPI); a ``takeoff_service`` of a wrapper can do them.

Frames: the robot's poses and setpoints are ENU in its own frame, whose origin is at
``offset`` (metres) in the mission's frame; poses are shifted by it on the way in,
setpoints on the way out. ``speed`` is not sent (position setpoints carry none): the robot
flies at its own controller's pace. Without a take-off service, ``takeoff(h)`` sets the
setpoint ``h`` metres above where the robot is; without a landing service, ``land`` sets
it on the ground below (z of the robot's frame = 0).

Link: no pose for ``pose_timeout`` seconds is the local event ``vehicle_link_lost``, the
next pose ``vehicle_link_restored`` (as a MAVLink vehicle's); a service that fails or never
answers is reported in :meth:`Ros2Vehicle.drain_errors` naming it. The operator's
``vehicle_land`` / ``vehicle_hold`` (:meth:`Ros2Vehicle.override`) take the vehicle from
the plugins until ``vehicle_resume``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Any, Final, Literal

from actorswarm.ros2 import messages as msgs
from actorswarm.ros2.load import Ros2Error, message_type
from actorswarm.ros2.node import Call, RosNode

__all__ = ["PROFILES", "Ros2Vehicle", "Ros2VehicleSettings"]


@dataclass(frozen=True, slots=True)
class Ros2VehicleSettings:
    """Where a ROS 2 robot's pose and setpoints travel (see the module docstring)."""

    pose_topic: str = "robot/pose"
    pose_type: str = "geometry_msgs/msg/PoseStamped"
    pose_qos: str = "reliable"
    setpoint_topic: str = "robot/setpoint"
    setpoint_qos: str = "reliable"
    frame: str = "map"
    takeoff_service: str | None = None
    land_service: str | None = None
    battery_topic: str | None = None
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rate: float = 10.0
    pose_timeout: float = 1.0
    service_timeout: float = 5.0
    profile: str = "generic"

    def __post_init__(self) -> None:
        if self.pose_type not in msgs.POSE_TYPES:
            raise ValueError(
                f"ros2 pose_type {self.pose_type!r}: the pose types are "
                + ", ".join(msgs.POSE_TYPES)
            )
        if not 0.5 <= self.rate <= 100:
            raise ValueError(f"ros2 rate {self.rate}: setpoints per second, 0.5 to 100")
        if self.pose_timeout <= 0 or self.service_timeout <= 0:
            raise ValueError("ros2 pose_timeout and service_timeout must be > 0 seconds")

    def for_platform(self, platform: int) -> Ros2VehicleSettings:
        """These settings with ``{platform}`` in the names replaced."""

        def fill(name: str | None) -> str | None:
            return None if name is None else name.replace("{platform}", str(platform))

        return replace(
            self,
            pose_topic=str(fill(self.pose_topic)),
            setpoint_topic=str(fill(self.setpoint_topic)),
            takeoff_service=fill(self.takeoff_service),
            land_service=fill(self.land_service),
            battery_topic=fill(self.battery_topic),
        )


#: The named profiles: the topics of Aerostack2, MAVROS, or the daemon's own namespace.
PROFILES: Final[dict[str, Ros2VehicleSettings]] = {
    "generic": Ros2VehicleSettings(),
    "aerostack2": Ros2VehicleSettings(
        pose_topic="/drone{platform}/self_localization/pose",
        pose_qos="sensor",
        setpoint_topic="/drone{platform}/motion_reference/pose",
        frame="earth",
        profile="aerostack2",
    ),
    "mavros": Ros2VehicleSettings(
        pose_topic="/mavros/local_position/pose",
        pose_qos="sensor",
        setpoint_topic="/mavros/setpoint_position/local",
        frame="map",
        profile="mavros",
    ),
}

#: Seconds between two poses for a velocity estimate (closer ones are averaged out).
_VELOCITY_DT: Final = 0.05


def _no_wake() -> None:
    """A subscription's wake that wakes nothing."""


class Ros2Vehicle:
    """The vehicle of a daemon whose robot speaks ROS 2, on ``node`` (see the module
    docstring). Its commands set the setpoint and return; the node's timer streams it."""

    def __init__(self, node: RosNode, settings: Ros2VehicleSettings) -> None:
        self.node = node
        self.settings = settings
        s = settings
        # A pose is read when wanted (position(), each wake): a robot publishing at 50 Hz
        # must not wake the daemon's loop 50 times a second.
        self._pose = node.subscribe(
            s.pose_topic, s.pose_type, qos=s.pose_qos, keep=1, wake=_no_wake
        )
        self._battery_inlet = (
            None
            if s.battery_topic is None
            else node.subscribe(
                s.battery_topic, "sensor_msgs/msg/BatteryState", keep=1, wake=_no_wake
            )
        )
        self._here: tuple[float, float, float] | None = None
        self._velocity = (0.0, 0.0, 0.0)
        self._seen_at: float | None = None
        self._last: tuple[float, tuple[float, float, float]] | None = None
        self._battery = 1.0
        #: The setpoint streamed (robot frame), None: none yet (nothing is sent).
        self._target: tuple[float, float, float] | None = None
        #: A take-off asked for before the first pose: its height, flown once located.
        self._pending_takeoff: float | None = None
        self._link: Literal["waiting", "up", "lost"] = "waiting"
        self._events: list[str] = []
        self._errors: list[str] = []
        self._faults: list[str] = []
        self._calls: list[tuple[str, Call]] = []
        self._override: Literal["land", "hold"] | None = None
        self._timer: Any = None
        self._setpoint_type = "geometry_msgs/msg/PoseStamped"
        node.publisher(s.setpoint_topic, self._setpoint_type, qos=s.setpoint_qos)

    # --- the daemon's side --------------------------------------------------------------

    def start(self) -> None:
        """Stream the setpoint from the node's thread (the node spins already or soon)."""
        self._timer = self.node.node.create_timer(1.0 / self.settings.rate, self._stream)

    def close(self) -> None:
        """Stop streaming (the node is closed by its owner)."""
        if self._timer is not None:
            self._timer.cancel()

    def _stream(self) -> None:
        target = self._target  # one read: the loop's thread replaces the tuple whole
        if target is None:
            return
        try:
            self.node.publish(
                self.settings.setpoint_topic,
                self._setpoint_type,
                msgs.pose_stamped(self.node.now_msg(), self.settings.frame, target),
                qos=self.settings.setpoint_qos,
            )
        except Ros2Error as exc:
            self.node.error(str(exc))

    def service(self, now: float | None = None) -> None:
        """(Loop thread.) Take the newest pose, watch the link and the service calls."""
        now = time.monotonic() if now is None else now
        self._take_pose(now)
        if self._battery_inlet is not None:
            state = self._battery_inlet.latest()
            if state is not None and math.isfinite(state.percentage):
                self._battery = min(1.0, max(0.0, float(state.percentage)))
        seen = self._seen_at
        if self._link == "up" and seen is not None and now - seen > self.settings.pose_timeout:
            self._link = "lost"
            self._events.append("vehicle_link_lost")
        for label, call in list(self._calls):
            if call.done():
                self._calls.remove((label, call))
                try:
                    answer = call.result()
                    if not getattr(answer, "success", True):
                        self._fail(f"{label}: refused: {answer.message}")
                except Ros2Error as exc:
                    self._fail(f"{label}: {exc}")

    def _take_pose(self, now: float) -> None:
        message = self._pose.latest()
        if message is not None:
            try:
                x, y, z = msgs.pose_of(message)
            except AttributeError as exc:
                self._errors.append(f"topic {self._pose.topic}: not a pose: {exc}")
            else:
                self._on_pose(now, (x, y, z), message)

    def _on_pose(self, now: float, robot: tuple[float, float, float], message: Any) -> None:
        self._here = robot
        twist = getattr(message, "twist", None)
        if twist is not None:  # Odometry says its velocity (in its child frame: see docs)
            v = twist.twist.linear
            self._velocity = (float(v.x), float(v.y), float(v.z))
        elif self._last is not None and now - self._last[0] >= _VELOCITY_DT:
            t0, (x0, y0, z0) = self._last
            dt = now - t0
            self._velocity = ((robot[0] - x0) / dt, (robot[1] - y0) / dt, (robot[2] - z0) / dt)
            self._last = (now, robot)
        elif self._last is None:
            self._last = (now, robot)
        self._seen_at = now
        if self._pending_takeoff is not None:
            self._target = (robot[0], robot[1], robot[2] + self._pending_takeoff)
            self._pending_takeoff = None
        if self._link != "up":
            if self._link == "lost":
                self._events.append("vehicle_link_restored")
            self._link = "up"

    def drain_events(self) -> list[str]:
        self.service()
        out, self._events = self._events, []
        return out

    def _fail(self, error: str) -> None:
        """A take-off or landing that failed for good (the service refused, never answered
        or is missing): an error, and a fault the daemon raises as ``vehicle_fault_event``
        (the service is not called again on its own)."""
        self._errors.append(error)
        self._faults.append(error)

    def drain_errors(self) -> list[str]:
        """What failed since the last call (a service that refused or never answered); the
        node's own errors are its owner's to drain."""
        out, self._errors = self._errors, []
        return out

    def drain_faults(self) -> list[str]:
        """The commands that failed for good since the last call, oldest first (each also
        in :meth:`drain_errors`), as the MAVLink vehicle's: the daemon raises
        ``vehicle_fault_event`` for each, with the reason as its data."""
        out, self._faults = self._faults, []
        return out

    def drain_log(self) -> list[tuple[str, dict[str, Any]]]:
        """Structured lines for the daemon's log: none (rclpy's own output is the node's,
        and the node's errors are its owner's to log)."""
        return []

    def status(self) -> dict[str, Any]:
        """What ``status.json`` and the ground station show of the vehicle."""
        out: dict[str, Any] = {
            "link": self._link,
            "autopilot": "ros2",
            "mode": self.settings.profile,
            "battery": self._battery if self.settings.battery_topic else None,
        }
        if self._override:
            out["override"] = self._override
        return out

    def override(self, action: Literal["land", "hold"] | None) -> None:
        """The operator's land or hold (None: give the vehicle back to the plugins)."""
        self._override = action
        if action == "land":
            self._land()
        elif action == "hold":
            self._hold()

    # --- Vehicle ------------------------------------------------------------------------

    def located(self) -> bool:
        """True once a pose came."""
        return self._here is not None

    def position(self) -> tuple[float, float, float]:
        self._take_pose(time.monotonic())  # the newest pose, not the one of the last wake
        ox, oy, oz = self.settings.offset
        x, y, z = self._here or (0.0, 0.0, 0.0)
        return x + ox, y + oy, z + oz

    def velocity(self) -> tuple[float, float, float]:
        return self._velocity

    def battery(self) -> float:
        return self._battery

    def goto(self, x: float, y: float, z: float, *, speed: float | None = None) -> None:
        if self._override is None:
            ox, oy, oz = self.settings.offset
            self._target = (x - ox, y - oy, z - oz)

    def hold(self) -> None:
        if self._override is None:
            self._hold()

    def land(self) -> None:
        if self._override is None:
            self._land()

    def takeoff(self, altitude: float) -> None:
        if self._override is not None:
            return
        if self._here is None:
            self._pending_takeoff = altitude  # no pose yet: where to climb is not known
        else:
            x, y, z = self._here
            self._target = (x, y, z + altitude)
        if self.settings.takeoff_service:
            self._trigger(self.settings.takeoff_service, "take-off")

    def _hold(self) -> None:
        if self._here is not None:
            self._target = self._here

    def _land(self) -> None:
        if self.settings.land_service:
            self._target = None  # the robot's own landing: no setpoint fights it
            self._trigger(self.settings.land_service, "landing")
        elif self._here is not None:
            self._target = (self._here[0], self._here[1], 0.0)

    def _trigger(self, service: str, what: str) -> None:
        request = message_type("std_srvs/srv/Trigger").Request()
        try:
            call = self.node.call(
                service, "std_srvs/srv/Trigger", request, timeout=self.settings.service_timeout
            )
        except Ros2Error as exc:
            self._fail(f"{what}: {exc}")
            return
        self._calls.append((f"{what} (service {call.service})", call))
