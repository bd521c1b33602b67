"""The daemon's configuration file (``actorswarm daemon --config FILE``), TOML.

Every command-line option of the daemon has a key of the same name (``-`` written ``_``);
an option given on the command line wins over the file, the file over the defaults. A
``[core]`` table tunes the collective core (:class:`~actorswarm.core.config.CoreConfig`:
``heartbeat_interval``, ``t_leave``, ...). Relative paths are relative to the file's
directory, so a robot's configuration can live beside its keys::

    platform = 3
    swarm = "field"
    listen = ["tcp/0.0.0.0:7447"]
    connect = ["tcp/192.168.1.10:7447"]
    multicast = false        # listed peers (with listen/connect): the mesh
    broadcast = "mesh"       # or "multicast": one datagram per broadcast on a group, the
                             # default when no listen, connect, multicast or relay is given
    # group = "224.0.0.225:7448"; interface = "wlan0"   (broadcast = "multicast" only)
    lease = 30.0             # Zenoh's session lease, seconds (docs/deploying.md)
    relay = false            # true: forward for the others, for a swarm beyond one radio hop
    keys = "keys"
    state_dir = "/var/lib/actorswarm"
    vehicle = "sim"          # or "none", or "mavlink"
    world = "world.toml"     # the simulated vehicle's world (--vehicle sim)
    fleet = "1-10"           # the swarm's platforms, for this one's home on the world's grid

A daemon flying a PX4 or ArduPilot autopilot (``vehicle = "mavlink"``) says where it is
and where the mission's origin is; the keys after these three exist only in the file::

    vehicle = "mavlink"
    mavlink = "/dev/ttyAMA0,921600"   # or "udpin:0.0.0.0:14540", "tcp:127.0.0.1:5760"
    mavlink_sysid = 1                  # the autopilot's system ID (default: the first heard)
    origin = "47.397742,8.545594,488"  # LAT,LON,ALT of the mission's origin, for the swarm
    mavlink_kind = "px4"               # "auto" (its HEARTBEAT says), "ardupilot" or "px4"
    mavlink_link_timeout = 3.0         # seconds of heartbeat silence: vehicle_link_lost
    mavlink_force = false              # take off even with the failsafes off
    mavlink_arm_timeout = 120.0        # seconds a take-off waits for the autopilot to be ready
    fence = [-300, -300, 300, 300, 60] # x_min, y_min, x_max, y_max, z_max: bounds every goal
    mavlink_push_fence = true          # also set the autopilot's own geofence to the fence

    [core]
    t_leave = 0.5

A ``[ros2]`` table gives the daemon a ROS 2 node (as ``--ros2`` does) and, with ``vehicle =
"ros2"``, says where the robot's topics are (:mod:`actorswarm.ros2.daemon`).

A wrong key, a wrong type or a value out of range is a :class:`DaemonConfigError` naming
the file and the key; nothing starts.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

import msgspec

from actorswarm.core.config import ConfigError, CoreConfig

__all__ = [
    "BOOT_WAIT",
    "HEARTBEAT_SLACK",
    "DaemonConfigError",
    "DaemonFile",
    "daemon_core",
    "load_daemon_config",
]

#: How long a daemon listens before it may claim mastership, unless ``[core] boot_wait``
#: says otherwise. The simulator's default (four heartbeat intervals) is too short for a
#: real network: a restarted low-ID daemon would claim the role before its Zenoh links are
#: up, then take it from the healthy master when they come up — a needless failover.
BOOT_WAIT = 2.0

#: How early a daemon may send a heartbeat on a wake it makes anyway, unless ``[core]
#: heartbeat_slack`` says otherwise (:class:`~actorswarm.core.config.CoreConfig`): a
#: member's heartbeats then ride on the wakes its master's heartbeats cause, one wake of
#: the loop instead of two per interval (docs/deploying.md, "CPU").
HEARTBEAT_SLACK = 0.03

Vehicle = Literal["none", "sim", "mavlink", "ros2"]


class DaemonConfigError(ValueError):
    """The configuration file cannot be used; the message names the file and the key."""


class DaemonFile(msgspec.Struct, forbid_unknown_fields=True, frozen=True):
    """What a daemon configuration file may say (every key optional)."""

    platform: Annotated[int, msgspec.Meta(ge=1, le=65535)] | None = None
    swarm: str | None = None
    listen: list[str] = []
    connect: list[str] = []
    multicast: bool | None = None
    broadcast: Literal["mesh", "multicast"] | None = None
    group: str | None = None
    interface: str | None = None
    lease: Annotated[float, msgspec.Meta(ge=0.1, le=3600)] | None = None
    relay: bool = False
    keys: str | None = None
    insecure: bool = False
    state_dir: str | None = None
    vehicle: Vehicle | None = None
    world: str | None = None
    mavlink: str | None = None
    mavlink_sysid: Annotated[int, msgspec.Meta(ge=1, le=255)] | None = None
    origin: str | None = None
    mavlink_kind: Literal["auto", "ardupilot", "px4"] = "auto"
    mavlink_link_timeout: Annotated[float, msgspec.Meta(gt=0)] = 3.0
    mavlink_force: bool = False
    mavlink_arm_timeout: Annotated[float, msgspec.Meta(gt=0)] = 120.0
    fence: Annotated[list[float], msgspec.Meta(min_length=5, max_length=5)] | None = None
    mavlink_push_fence: bool = False
    fleet: str | None = None
    transport: Literal["zenoh"] | None = None
    core: dict[str, Any] = {}
    #: The ``[ros2]`` table (checked by :func:`actorswarm.ros2.daemon.ros2_options`).
    ros2: dict[str, Any] | None = None

    def path(self, value: str | None, base: Path) -> Path | None:
        """``value`` as a path, relative to ``base`` (the file's directory)."""
        if value is None:
            return None
        p = Path(value).expanduser()
        return p if p.is_absolute() else base / p


def daemon_core(core: CoreConfig) -> CoreConfig:
    """``core`` with the daemon's :data:`BOOT_WAIT` when it sets no ``boot_wait``, and its
    :data:`HEARTBEAT_SLACK` (at most half the heartbeat interval) when it sets no
    ``heartbeat_slack``."""
    if core.boot_wait is None:
        core = core.replace(boot_wait=BOOT_WAIT)
    if core.heartbeat_slack is None:
        core = core.replace(heartbeat_slack=min(HEARTBEAT_SLACK, core.heartbeat_interval / 2))
    return core


def load_daemon_config(path: Path) -> tuple[DaemonFile, CoreConfig]:
    """The file at ``path`` and the core configuration its ``[core]`` table makes."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise DaemonConfigError(f"{path}: cannot read: {exc.strerror or exc}") from None
    try:
        parsed = msgspec.toml.decode(data, type=DaemonFile)
    except msgspec.ValidationError as exc:
        known = ", ".join(DaemonFile.__struct_fields__)
        raise DaemonConfigError(f"{path}: {exc} (the keys are: {known})") from None
    except msgspec.DecodeError as exc:
        raise DaemonConfigError(f"{path}: not TOML: {exc}") from None
    from actorswarm.transport.zenoh_transport import check_group, check_interface

    for key, check in (("group", check_group), ("interface", check_interface)):
        value = getattr(parsed, key)
        if value is not None:
            try:
                check(value)
            except ValueError as exc:
                raise DaemonConfigError(f"{path}: {key}: {exc}") from None
    try:
        core = CoreConfig.from_mapping(dict(parsed.core))
    except ConfigError as exc:
        raise DaemonConfigError(f"{path}: [core]: {exc}") from None
    return parsed, core
