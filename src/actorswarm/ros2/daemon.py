"""A daemon's ROS 2 options: ``--ros2``, ``--vehicle ros2``, ``--ros2-profile`` and the
``[ros2]`` table of its configuration file.

The table (every key optional)::

    [ros2]
    domain = 7                        # ROS_DOMAIN_ID of the node (default: the environment's)
    profile = "mavros"                # --vehicle ros2: generic, aerostack2 or mavros
    pose_topic = "/robot{platform}/pose"
    pose_type = "nav_msgs/msg/Odometry"   # or geometry_msgs/msg/PoseStamped, ...
    pose_qos = "sensor"               # reliable, sensor or latched
    setpoint_topic = "/robot{platform}/setpoint"
    setpoint_qos = "reliable"
    frame = "map"                     # the frame_id of the setpoints
    takeoff_service = "takeoff"       # std_srvs/Trigger (optional)
    land_service = "land"             # std_srvs/Trigger (optional)
    battery_topic = "battery"         # sensor_msgs/BatteryState (optional)
    offset = [0.0, 0.0, 0.0]          # the robot's frame origin in the mission frame, m
    rate = 10.0                       # setpoints per second
    pose_timeout = 1.0                # seconds without a pose: vehicle_link_lost

The vehicle's keys start from the profile's values. This module imports no ROS: the
daemon's options are checked before anything starts, and rclpy is loaded by
:func:`open_ros` in the running daemon.
"""

from __future__ import annotations

import asyncio
from dataclasses import dataclass, replace
from typing import Annotated, Any, Literal

import msgspec

from actorswarm.ros2.vehicle import PROFILES, Ros2VehicleSettings

__all__ = ["Ros2Options", "Ros2Table", "open_ros", "ros2_options"]


class Ros2Table(msgspec.Struct, forbid_unknown_fields=True, frozen=True):
    """What a ``[ros2]`` table may say."""

    domain: Annotated[int, msgspec.Meta(ge=0, le=232)] | None = None
    profile: Literal["generic", "aerostack2", "mavros"] | None = None
    pose_topic: str | None = None
    pose_type: str | None = None
    pose_qos: Literal["reliable", "sensor", "latched"] | None = None
    setpoint_topic: str | None = None
    setpoint_qos: Literal["reliable", "sensor", "latched"] | None = None
    frame: str | None = None
    takeoff_service: str | None = None
    land_service: str | None = None
    battery_topic: str | None = None
    offset: Annotated[list[float], msgspec.Meta(min_length=3, max_length=3)] | None = None
    rate: float | None = None
    pose_timeout: float | None = None


@dataclass(frozen=True, slots=True)
class Ros2Options:
    """A daemon's ROS 2: its node's ``domain`` (None: the environment's), and the vehicle's
    settings with ``--vehicle ros2`` (None: the node serves the plugins only)."""

    domain: int | None = None
    vehicle: Ros2VehicleSettings | None = None


def ros2_options(
    table: dict[str, Any] | None, *, vehicle: bool, profile: str | None, platform: int
) -> Ros2Options:
    """The options of a ``[ros2]`` ``table`` (None: none given), ``--vehicle ros2`` or not,
    ``--ros2-profile``; ValueError naming the key when something is wrong."""
    try:
        parsed = msgspec.convert(table or {}, Ros2Table)
    except msgspec.ValidationError as exc:
        known = ", ".join(Ros2Table.__struct_fields__)
        raise ValueError(f"[ros2]: {exc} (the keys are: {known})") from None
    if not vehicle:
        return Ros2Options(domain=parsed.domain)
    name = profile or parsed.profile or "generic"
    if name not in PROFILES:
        raise ValueError(f"--ros2-profile {name!r}: the profiles are {', '.join(PROFILES)}")
    keys = {
        k: getattr(parsed, k)
        for k in Ros2Table.__struct_fields__
        if k not in ("domain", "profile") and getattr(parsed, k) is not None
    }
    if "offset" in keys:
        keys["offset"] = tuple(keys["offset"])
    try:
        settings = replace(PROFILES[name], **keys)
    except ValueError as exc:
        raise ValueError(f"[ros2]: {exc}") from None
    return Ros2Options(domain=parsed.domain, vehicle=settings.for_platform(platform))


def open_ros(
    options: Ros2Options, platform: int, swarm: str, loop: asyncio.AbstractEventLoop
) -> tuple[Any, Any]:
    """The platform's node (:class:`~actorswarm.ros2.platform.PlatformRos`) and its vehicle
    (:class:`~actorswarm.ros2.vehicle.Ros2Vehicle`, None without ``--vehicle ros2``);
    :class:`~actorswarm.ros2.load.Ros2Error` when the node cannot be made."""
    from actorswarm.ros2.platform import PlatformRos
    from actorswarm.ros2.vehicle import Ros2Vehicle

    ros = PlatformRos(platform, swarm, loop, domain=options.domain)
    vehicle = None
    if options.vehicle is not None:
        try:
            vehicle = Ros2Vehicle(ros.node, options.vehicle)
        except Exception:
            ros.close()
            raise
    return ros, vehicle
