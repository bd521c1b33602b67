"""``actorswarm daemon``: one platform of a real swarm, until SIGTERM or SIGINT.

Options come from the command line, then the ``--config`` file
(:mod:`actorswarm.daemon.config`), then the defaults. Every problem with them is reported
before anything starts, with exit status 2.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from actorswarm.cli.swarm_options import (
    ConnectOpt,
    InsecureOpt,
    KeysOpt,
    ListenOpt,
    check_swarm,
    packet_guard,
    zenoh_settings,
)

__all__ = ["daemon"]


def _fail(message: str) -> typer.Exit:
    typer.echo(message, err=True)
    return typer.Exit(2)


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
        typer.Option("--multicast/--no-multicast", help="Multicast scouting (default on)."),
    ] = None,
    state_dir: Annotated[
        Path | None, typer.Option(help="Where the platform keeps its state (default ./state-ID).")
    ] = None,
    keys: KeysOpt = None,
    insecure: InsecureOpt = False,
    vehicle: Annotated[
        str | None,
        typer.Option(help="none (default), or sim: fly a simulated vehicle in this process."),
    ] = None,
    world: Annotated[
        Path | None, typer.Option(help="The simulated vehicle's world file (TOML; --vehicle sim).")
    ] = None,
    config: Annotated[
        Path | None,
        typer.Option(help="A TOML file with any of these options (and a \\[core] table)."),
    ] = None,
) -> None:
    """Run one platform of a real swarm over Zenoh until SIGTERM/SIGINT."""
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
            raise _fail(str(exc)) from None
        base = config.resolve().parent
    platform = platform if platform is not None else file.platform
    if platform is None:
        raise _fail("which platform is this? give --platform ID (or platform = ID in --config)")
    swarm = swarm or file.swarm or "swarm"
    check_swarm(swarm)
    chosen_transport = transport or file.transport or "zenoh"
    if chosen_transport != "zenoh":
        raise _fail(f"--transport {chosen_transport!r}: the transports are: zenoh")
    chosen_vehicle = vehicle or file.vehicle or "none"
    if chosen_vehicle not in ("none", "sim"):
        raise _fail(f"--vehicle {chosen_vehicle!r}: the vehicles are: none, sim")
    world_file = world or file.path(file.world, base)
    if world_file is not None and chosen_vehicle != "sim":
        raise _fail("--world describes a simulated vehicle's world: give --vehicle sim too")
    if world_file is not None and not world_file.is_file():
        raise _fail(f"--world {world_file}: no such file")
    world_config = None
    if chosen_vehicle == "sim":
        from actorswarm.world.config import WorldError, load_world

        try:
            world_config = load_world(world_file)
        except WorldError as exc:
            raise _fail(str(exc)) from None
    guard = packet_guard(keys or file.path(file.keys, base), insecure or file.insecure, "platform")
    settings = zenoh_settings(
        list(connect or file.connect) or None,
        list(listen or file.listen) or None,
        multicast if multicast is not None else file.multicast is not False,
    )
    options = DaemonOptions(
        guard=guard,
        platform=platform,
        swarm=swarm,
        state_dir=state_dir or file.path(file.state_dir, base) or Path(f"state-{platform}"),
        zenoh=settings,
        config=daemon_core(core),
        world=world_config,
    )
    raise typer.Exit(run_daemon(options))
