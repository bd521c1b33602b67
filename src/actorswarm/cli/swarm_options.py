"""What every command that talks to a real swarm shares: its options (swarm name, Zenoh
endpoints, keys) and turning them into a transport configuration and a packet guard, with
a clear error and exit status 2 when they are not usable."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Literal

import typer

from actorswarm.security.guard import PacketGuard
from actorswarm.transport.zenoh_transport import ZenohSettings, key_prefix

if TYPE_CHECKING:
    from actorswarm.daemon.ground import GroundSession

__all__ = [
    "ConnectOpt",
    "InsecureOpt",
    "KeysOpt",
    "Link",
    "ListenOpt",
    "MulticastOpt",
    "SwarmOpt",
    "TimeoutOpt",
    "default_state_file",
    "link",
    "packet_guard",
    "zenoh_settings",
]

SwarmOpt = Annotated[str, typer.Option(help="The swarm's name (its Zenoh namespace).")]
ConnectOpt = Annotated[
    list[str] | None, typer.Option(help="Zenoh endpoint to connect to (repeatable).")
]
ListenOpt = Annotated[list[str] | None, typer.Option(help="Zenoh endpoint to listen on.")]
MulticastOpt = Annotated[
    bool, typer.Option("--multicast/--no-multicast", help="Multicast scouting of peers.")
]
TimeoutOpt = Annotated[float, typer.Option(min=0.1, help="Seconds to wait for the swarm.")]
KeysOpt = Annotated[
    Path | None,
    typer.Option(help="The swarm's key directory (default: the user's; see `keys init`)."),
]
InsecureOpt = Annotated[
    bool, typer.Option("--insecure", help="No packet authentication (trusted networks only).")
]


def packet_guard(
    keys: Path | None, insecure: bool, role: Literal["platform", "ground"]
) -> PacketGuard:
    """The packet guard for ``role``, or a clear error and exit 2 when the keys are not
    usable."""
    from actorswarm.security import KeyFileError, default_key_dir, load_keys

    if insecure:
        typer.echo("WARNING: --insecure: packets are not authenticated", err=True)
        return PacketGuard.insecure()
    directory = keys or default_key_dir()
    try:
        loaded = load_keys(directory, need_private=role == "ground")
    except KeyFileError as exc:
        typer.echo(
            f"{exc}\ncreate keys with `actorswarm keys init --dir {directory}` and copy "
            "swarm.key and ground_station.pub to every platform, or run with --insecure",
            err=True,
        )
        raise typer.Exit(2) from None
    return PacketGuard.from_keys(loaded, role=role)


def zenoh_settings(
    connect: list[str] | None, listen: list[str] | None, multicast: bool
) -> ZenohSettings:
    return ZenohSettings(
        listen=tuple(listen or ()), connect=tuple(connect or ()), multicast=multicast
    )


def check_swarm(swarm: str) -> None:
    """Exit 2 with the reason when ``swarm`` cannot be a swarm's name."""
    try:
        key_prefix(swarm)
    except ValueError as exc:
        typer.echo(str(exc), err=True)
        raise typer.Exit(2) from None


@dataclass(frozen=True, slots=True)
class Link:
    """How a ground-station command reaches the swarm."""

    swarm: str
    settings: ZenohSettings
    guard: PacketGuard

    def session(self, patience: float | None = None) -> GroundSession:
        """A new ground-station session over this link (``async with``) whose commands are
        retransmitted for ``patience`` seconds (a command's ``--timeout``)."""
        from actorswarm.daemon.ground import GroundSession

        return GroundSession(self.swarm, self.settings, self.guard, patience=patience)


def link(
    swarm: str,
    connect: list[str] | None,
    listen: list[str] | None,
    multicast: bool,
    keys: Path | None,
    insecure: bool,
) -> Link:
    """The ground station's link from its command-line options (exit 2 when unusable)."""
    check_swarm(swarm)
    return Link(
        swarm, zenoh_settings(connect, listen, multicast), packet_guard(keys, insecure, "ground")
    )


def default_state_file(swarm: str) -> Path:
    """Where ``gs deploy`` remembers what it deployed to ``swarm``."""
    base = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(base) / "actorswarm" / f"gs-{swarm}.json"
