"""``actorswarm daemon``: one platform of a real swarm, until SIGTERM or SIGINT.

Options come from the command line, then the ``--config`` file
(:mod:`actorswarm.daemon.config`), then the defaults. Every problem with them is reported
before anything starts, with exit status 2. What the command does is in
:mod:`actorswarm.cli.daemon_start`, which :func:`actorswarm.cli.main` also calls directly for
a well-formed command line (without loading typer); the options declared here are the
reference that module's reader follows.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from actorswarm.cli.daemon_start import start_daemon

# The daemon's own (the ground station's read the environment too, cli.swarm_options).
ConnectOpt = Annotated[
    list[str] | None,
    typer.Option(metavar="ENDPOINT", help="Zenoh endpoint to connect to (repeatable)."),
]
ListenOpt = Annotated[
    list[str] | None, typer.Option(metavar="ENDPOINT", help="Zenoh endpoint to listen on.")
]
KeysOpt = Annotated[
    Path | None,
    typer.Option(help="The swarm's key directory (default: the user's; see `keys init`)."),
]
InsecureOpt = Annotated[
    bool, typer.Option("--insecure", help="No packet authentication (trusted networks only).")
]

__all__ = ["daemon"]


def daemon(
    platform: Annotated[
        int | None,
        typer.Option(min=1, max=65535, help="This platform's ID (or `platform` in --config)."),
    ] = None,
    swarm: Annotated[
        str | None, typer.Option(help="The swarm's name (its Zenoh namespace; default swarm).")
    ] = None,
    transport: Annotated[
        str | None, typer.Option(help="The network: zenoh (the default, the only one so far).")
    ] = None,
    listen: ListenOpt = None,
    connect: ConnectOpt = None,
    multicast: Annotated[
        bool | None,
        typer.Option(
            "--multicast/--no-multicast",
            help="Multicast scouting of peers on the mesh (either flag puts the platform on "
            "the mesh: --no-multicast for listed peers).",
        ),
    ] = None,
    broadcast: Annotated[
        str | None,
        typer.Option(
            help="How broadcasts travel: multicast (the default unless --listen, --connect, "
            "--[no-]multicast or --relay is given: one datagram on --group, which then carries "
            "everything) or mesh (one copy per peer over Zenoh sessions)."
        ),
    ] = None,
    group: Annotated[
        str | None,
        typer.Option(help="The multicast group, ADDRESS:PORT (default 224.0.0.225:7448)."),
    ] = None,
    interface: Annotated[
        str | None,
        typer.Option(help="The network interface of the multicast group (wlan0; default: any)."),
    ] = None,
    lease: Annotated[
        float | None,
        typer.Option(
            min=0.1,
            max=3600,
            help="Zenoh's session lease, seconds (default 30): how long Zenoh keeps a silent "
            "peer's session; four keep-alives per lease on each idle link.",
        ),
    ] = None,
    relay: Annotated[
        bool,
        typer.Option(
            "--relay",
            help="Forward the others' packets (Zenoh router, link-state routing): for a swarm "
            "whose platforms reach only their neighbours. Not with --broadcast multicast.",
        ),
    ] = False,
    state_dir: Annotated[
        Path | None,
        typer.Option(
            help="Where the platform keeps its state (default: "
            "$XDG_STATE_HOME/actorswarm/SWARM/platform-ID, or ~/.local/state/actorswarm/... "
            "without XDG_STATE_HOME)."
        ),
    ] = None,
    keys: KeysOpt = None,
    insecure: InsecureOpt = False,
    vehicle: Annotated[
        str | None,
        typer.Option(
            help="none (default); sim: fly a simulated vehicle in this process; mavlink: fly "
            "a PX4 or ArduPilot autopilot (--mavlink, --origin); ros2: a robot that speaks "
            "ROS 2 (--ros2-profile, [ros2] in --config)."
        ),
    ] = None,
    world: Annotated[
        Path | None, typer.Option(help="The simulated vehicle's world file (TOML; --vehicle sim).")
    ] = None,
    mavlink: Annotated[
        str | None,
        typer.Option(
            help="The autopilot's MAVLink connection (--vehicle mavlink): udpin:HOST:PORT, "
            "udpout:HOST:PORT, tcp:HOST:PORT, or a serial device /dev/ttyACM0,57600."
        ),
    ] = None,
    mavlink_sysid: Annotated[
        int | None,
        typer.Option(
            min=1, max=255, help="The autopilot's MAVLink system ID (default: the first heard)."
        ),
    ] = None,
    origin: Annotated[
        str | None,
        typer.Option(help="The mission's origin, LAT,LON,ALT (--vehicle mavlink)."),
    ] = None,
    fleet: Annotated[
        str | None,
        typer.Option(
            metavar="IDS",
            help="The swarm's platform IDs (e.g. 1-10; default: the world's fleet.platforms), "
            "so --vehicle sim starts at this platform's home on the world's grid, as in the "
            "simulator.",
        ),
    ] = None,
    config: Annotated[
        Path | None,
        typer.Option(help="A TOML file with any of these options (and a [core] table)."),
    ] = None,
    ros2: Annotated[
        bool,
        typer.Option(
            "--ros2",
            help="A ROS 2 node for the plugins (ctx.ros2; needs actorswarm[ros2] or a sourced "
            "ROS 2); the daemon runs on without it when it cannot be made.",
        ),
    ] = False,
    ros2_profile: Annotated[
        str | None,
        typer.Option(help="--vehicle ros2: the robot's topics, generic, aerostack2 or mavros."),
    ] = None,
) -> None:
    """Run one platform of a real swarm over Zenoh until SIGTERM/SIGINT."""
    raise typer.Exit(
        start_daemon(
            platform=platform,
            swarm=swarm,
            transport=transport,
            listen=listen,
            connect=connect,
            multicast=multicast,
            broadcast=broadcast,
            group=group,
            interface=interface,
            lease=lease,
            relay=relay,
            state_dir=state_dir,
            keys=keys,
            insecure=insecure,
            vehicle=vehicle,
            world=world,
            fleet=fleet,
            config=config,
            mavlink=mavlink,
            mavlink_sysid=mavlink_sysid,
            origin=origin,
            ros2=ros2,
            ros2_profile=ros2_profile,
        )
    )
