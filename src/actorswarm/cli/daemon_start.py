"""``actorswarm daemon`` without typer: what the command does once its options are known
(:func:`start_daemon`), and a strict reader of its command line (:func:`parse_daemon_args`).

A robot's daemon runs for hours in its own process: everything imported before it starts
stays in its memory. :func:`actorswarm.cli.main` therefore reads a well-formed ``daemon``
command line here and starts the daemon without loading typer, rich or the other commands'
modules. The reader accepts only what the typer command
(:func:`actorswarm.cli.daemon_cmd.daemon`) accepts, with the same meaning; for anything else
— ``--help``, an unknown option, a missing or malformed value, a repeated option — it
answers None and the full command line handles the arguments, so the help and every usage
error are typer's own. The checks after parsing (:func:`start_daemon`) are shared by both
paths.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

__all__ = ["LEASE_RANGE", "OPTIONS", "parse_daemon_args", "start_daemon"]

#: The daemon's options: command-line name -> (parameter, kind). ``value``: one string;
#: ``int``: a platform ID; ``sysid``: a MAVLink system ID; ``path``: a file or directory;
#: ``seconds``: a Zenoh lease in seconds; ``list``: repeatable; ``flag``: True when given;
#: ``on``/``off``: the two sides of a boolean switch.
OPTIONS: dict[str, tuple[str, str]] = {
    "--platform": ("platform", "int"),
    "--swarm": ("swarm", "value"),
    "--transport": ("transport", "value"),
    "--listen": ("listen", "list"),
    "--connect": ("connect", "list"),
    "--multicast": ("multicast", "on"),
    "--no-multicast": ("multicast", "off"),
    "--broadcast": ("broadcast", "value"),
    "--group": ("group", "value"),
    "--interface": ("interface", "value"),
    "--lease": ("lease", "seconds"),
    "--relay": ("relay", "flag"),
    "--state-dir": ("state_dir", "path"),
    "--keys": ("keys", "path"),
    "--insecure": ("insecure", "flag"),
    "--vehicle": ("vehicle", "value"),
    "--world": ("world", "path"),
    "--mavlink": ("mavlink", "value"),
    "--mavlink-sysid": ("mavlink_sysid", "sysid"),
    "--origin": ("origin", "value"),
    "--fleet": ("fleet", "value"),
    "--config": ("config", "path"),
    "--ros2": ("ros2", "flag"),
    "--ros2-profile": ("ros2_profile", "value"),
}

#: The Zenoh lease, seconds, the typer command accepts (``min=0.1, max=3600``).
LEASE_RANGE = (0.1, 3600.0)

#: The values the typer command checks itself (``min=1, max=65535``; ``min=1, max=255``).
_RANGES = {"int": range(1, 65536), "sysid": range(1, 256)}


def parse_daemon_args(args: Sequence[str]) -> dict[str, Any] | None:
    """The keyword arguments of :func:`start_daemon` for the daemon's command line ``args``
    (what follows ``daemon``), or None when the full command line must handle them."""
    values: dict[str, Any] = {
        "platform": None,
        "swarm": None,
        "transport": None,
        "listen": None,
        "connect": None,
        "multicast": None,
        "broadcast": None,
        "group": None,
        "interface": None,
        "lease": None,
        "relay": False,
        "state_dir": None,
        "keys": None,
        "insecure": False,
        "vehicle": None,
        "world": None,
        "mavlink": None,
        "mavlink_sysid": None,
        "origin": None,
        "fleet": None,
        "config": None,
        "ros2": False,
        "ros2_profile": None,
    }
    given: set[str] = set()
    i = 0
    while i < len(args):
        name, eq, inline = args[i].partition("=")
        i += 1
        spec = OPTIONS.get(name)
        if spec is None:
            return None  # --help, a positional argument, an unknown option, "--"
        param, kind = spec
        if kind in ("flag", "on", "off"):
            if eq or param in given:
                return None
            given.add(param)
            values[param] = kind != "off"
            continue
        if eq:
            text = inline
        elif i < len(args):
            text = args[i]
            i += 1
        else:
            return None  # the option's value is missing
        if not text or text.startswith("-"):
            return None
        if kind == "list":
            values[param] = [*(values[param] or []), text]
            continue
        if param in given:
            return None
        given.add(param)
        if kind in _RANGES:
            if not (text.isascii() and text.isdigit()) or int(text) not in _RANGES[kind]:
                return None
            values[param] = int(text)
        elif kind == "seconds":
            try:
                seconds = float(text)
            except ValueError:
                return None
            if not LEASE_RANGE[0] <= seconds <= LEASE_RANGE[1]:
                return None  # also NaN
            values[param] = seconds
        elif kind == "path":
            values[param] = Path(text)
        else:
            values[param] = text
    return values


def start_daemon(
    *,
    platform: int | None,
    swarm: str | None,
    transport: str | None,
    listen: list[str] | None,
    connect: list[str] | None,
    multicast: bool | None,
    state_dir: Path | None,
    keys: Path | None,
    insecure: bool,
    vehicle: str | None,
    world: Path | None,
    config: Path | None,
    mavlink: str | None = None,
    mavlink_sysid: int | None = None,
    origin: str | None = None,
    fleet: str | None = None,
    broadcast: str | None = None,
    group: str | None = None,
    interface: str | None = None,
    lease: float | None = None,
    relay: bool = False,
    ros2: bool = False,
    ros2_profile: str | None = None,
) -> int:
    """Check the options (the command line, then the ``--config`` file, then the defaults)
    and run the daemon until a signal; returns its exit status. A problem with the options
    is printed on stderr and raises SystemExit(2) before anything starts."""
    from actorswarm.cli.swarm_setup import (
        busy_endpoint,
        check_swarm,
        default_daemon_state,
        packet_guard,
        refuse,
        zenoh_settings,
    )
    from actorswarm.core.config import CoreConfig
    from actorswarm.daemon.config import (
        DaemonConfigError,
        DaemonFile,
        daemon_core,
        load_daemon_config,
    )
    from actorswarm.daemon.run import DaemonOptions, run_daemon

    file, core = DaemonFile(), CoreConfig()
    base = Path.cwd()
    if config is not None:
        try:
            file, core = load_daemon_config(config)
        except DaemonConfigError as exc:
            raise refuse(str(exc)) from None
        base = config.resolve().parent
    platform = platform if platform is not None else file.platform
    if platform is None:
        raise refuse("which platform is this? give --platform ID (or platform = ID in --config)")
    swarm = swarm or file.swarm or "swarm"
    check_swarm(swarm)
    chosen_transport = transport or file.transport or "zenoh"
    if chosen_transport != "zenoh":
        raise refuse(f"--transport {chosen_transport!r}: the transports are: zenoh")
    chosen_vehicle = vehicle or file.vehicle or "none"
    if chosen_vehicle not in ("none", "sim", "mavlink", "ros2"):
        raise refuse(f"--vehicle {chosen_vehicle!r}: the vehicles are: none, sim, mavlink, ros2")
    world_file = world or file.path(file.world, base)
    if world_file is not None and chosen_vehicle != "sim":
        raise refuse("--world describes a simulated vehicle's world: give --vehicle sim too")
    if world_file is not None and not world_file.is_file():
        raise refuse(f"--world {world_file}: no such file")
    fleet_text = fleet or file.fleet
    if fleet_text is not None and chosen_vehicle != "sim":
        raise refuse("--fleet places a simulated vehicle on the world's grid: give --vehicle sim")
    world_config = None
    if chosen_vehicle == "sim":
        from actorswarm.world.config import WorldError, load_world, parse_platforms

        try:
            fleet_ids = None if fleet_text is None else parse_platforms(fleet_text)
        except ValueError as exc:
            raise refuse(f"--fleet {fleet_text!r}: {exc}") from None
        try:
            # The vehicle starts at this platform's home on the fleet's grid, as in the
            # simulator, not at the grid's first slot.
            world_config = load_world(world_file).alone(platform, fleet_ids)
        except WorldError as exc:
            raise refuse(str(exc)) from None
    autopilot = None
    if chosen_vehicle == "mavlink":
        autopilot = _mavlink_vehicle(platform, file, mavlink, mavlink_sysid, origin)
    elif mavlink is not None or mavlink_sysid is not None or origin is not None:
        raise refuse("--mavlink, --mavlink-sysid and --origin need --vehicle mavlink")
    ros2_options = _ros2(platform, file, chosen_vehicle, ros2, ros2_profile)
    guard = packet_guard(keys or file.path(file.keys, base), insecure or file.insecure, "platform")
    settings = zenoh_settings(
        list(connect or file.connect) or None,
        list(listen or file.listen) or None,
        multicast if multicast is not None else file.multicast,
        broadcast or file.broadcast,
        group or file.group,
        interface or file.interface,
        lease if lease is not None else file.lease,
        relay or file.relay,
    )
    for endpoint in settings.listen:
        problem = busy_endpoint(endpoint)
        if problem is not None:
            raise refuse(f"{problem}; choose another --listen endpoint")
    options = DaemonOptions(
        guard=guard,
        platform=platform,
        swarm=swarm,
        state_dir=state_dir
        or file.path(file.state_dir, base)
        or default_daemon_state(swarm, platform),
        zenoh=settings,
        config=daemon_core(core),
        world=world_config,
        autopilot=autopilot,
        ros2=ros2_options,
    )
    return run_daemon(options)


def _ros2(platform: int, file: Any, vehicle: str, flag: bool, profile: str | None) -> Any:
    """The daemon's ROS 2 options (None: no ROS 2), checked before anything starts; with
    --vehicle ros2, rclpy must be importable (the platform has no vehicle otherwise)."""
    from actorswarm.cli.swarm_setup import refuse

    if not (flag or vehicle == "ros2" or file.ros2 is not None):
        if profile is not None:
            raise refuse("--ros2-profile needs --vehicle ros2")
        return None
    from actorswarm.ros2.daemon import ros2_options

    try:
        options = ros2_options(
            file.ros2, vehicle=vehicle == "ros2", profile=profile, platform=platform
        )
    except ValueError as exc:
        raise refuse(str(exc)) from None
    if vehicle == "ros2":
        from actorswarm.ros2.load import Ros2Unavailable, load_rclpy

        try:
            load_rclpy()
        except Ros2Unavailable as exc:
            raise refuse(f"--vehicle ros2: {exc}") from None
    return options


def _mavlink_vehicle(
    platform: int, file: Any, url: str | None, sysid: int | None, origin: str | None
) -> Any:
    """The MAVLink vehicle of ``--vehicle mavlink`` with its connection open (pymavlink is
    imported here, only for such a daemon); a refusal naming what is wrong otherwise."""
    from actorswarm.cli.swarm_setup import refuse

    url = url or file.mavlink
    origin = origin or file.origin
    if not url:
        raise refuse("--vehicle mavlink: give --mavlink URL (udpin:0.0.0.0:14540, /dev/ttyACM0)")
    if not origin:
        raise refuse("--vehicle mavlink: give --origin LAT,LON,ALT (the mission's origin)")
    from actorswarm.vehicles.mavlink import MavlinkError
    from actorswarm.vehicles.mavlink.frame import parse_origin
    from actorswarm.vehicles.mavlink.vehicle import Fence, MavlinkSettings, MavlinkVehicle

    try:
        frame = parse_origin(origin, "--origin")
        fence = Fence(*file.fence) if file.fence is not None else Fence()
    except ValueError as exc:
        raise refuse(str(exc)) from None
    settings = MavlinkSettings(
        url,
        frame,
        system=sysid if sysid is not None else file.mavlink_sysid,
        kind=file.mavlink_kind,
        link_timeout=file.mavlink_link_timeout,
        force=file.mavlink_force,
        arm_timeout=file.mavlink_arm_timeout,
        fence=fence,
        name=f"platform {platform}",
        push_fence=file.mavlink_push_fence,
    )
    try:
        return MavlinkVehicle(settings)
    except MavlinkError as exc:
        raise refuse(str(exc)) from None
