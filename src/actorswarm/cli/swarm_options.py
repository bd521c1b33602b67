"""What every command that talks to a real swarm shares: its options (swarm name, Zenoh
endpoints, keys) and turning them into a transport configuration and a packet guard, with
a clear error and exit status 2 when they are not usable (:mod:`.swarm_setup`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from actorswarm.cli.swarm_setup import check_swarm, packet_guard, user_state_dir, zenoh_settings
from actorswarm.security.guard import PacketGuard
from actorswarm.transport.zenoh_transport import ZenohSettings

if TYPE_CHECKING:
    from actorswarm.daemon.ground import GroundSession

__all__ = [
    "BroadcastOpt",
    "ConnectOpt",
    "GroupOpt",
    "InsecureOpt",
    "InterfaceOpt",
    "KeysOpt",
    "Link",
    "ListenOpt",
    "MulticastOpt",
    "SwarmOpt",
    "TimeoutOpt",
    "check_swarm",
    "default_state_file",
    "link",
    "packet_guard",
    "zenoh_settings",
]

# The ground station's connection options also come from the environment or a profile
# (actorswarm.cli.profile): ACTORSWARM_SWARM, ACTORSWARM_CONNECT...
SwarmOpt = Annotated[
    str, typer.Option(envvar="ACTORSWARM_SWARM", help="The swarm's name (its Zenoh namespace).")
]
ConnectOpt = Annotated[
    list[str] | None,
    typer.Option(
        metavar="ENDPOINT",
        envvar="ACTORSWARM_CONNECT",
        help="Zenoh endpoint to connect to (repeatable).",
    ),
]
ListenOpt = Annotated[
    list[str] | None,
    typer.Option(
        metavar="ENDPOINT", envvar="ACTORSWARM_LISTEN", help="Zenoh endpoint to listen on."
    ),
]
MulticastOpt = Annotated[
    bool | None,
    typer.Option(
        "--multicast/--no-multicast",
        envvar="ACTORSWARM_MULTICAST",
        help="Multicast scouting of peers (default on with --broadcast mesh, off with multicast).",
    ),
]
BroadcastOpt = Annotated[
    str | None,
    typer.Option(
        envvar="ACTORSWARM_BROADCAST",
        help="How the swarm's broadcasts travel: mesh (the default) or multicast (everything "
        "on --group; every platform must say the same).",
    ),
]
GroupOpt = Annotated[
    str | None,
    typer.Option(
        envvar="ACTORSWARM_GROUP",
        help="The multicast group, ADDRESS:PORT (default 224.0.0.225:7448).",
    ),
]
InterfaceOpt = Annotated[
    str | None,
    typer.Option(
        envvar="ACTORSWARM_INTERFACE",
        help="The network interface of the multicast group (wlan0; default: any).",
    ),
]
TimeoutOpt = Annotated[float, typer.Option(min=0.1, help="Seconds to wait for the swarm.")]
KeysOpt = Annotated[
    Path | None,
    typer.Option(
        envvar="ACTORSWARM_KEYS",
        help="The swarm's key directory (default: the user's; see `keys init`).",
    ),
]
InsecureOpt = Annotated[
    bool,
    typer.Option(
        "--insecure",
        envvar="ACTORSWARM_INSECURE",
        help="No packet authentication (trusted networks only).",
    ),
]


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
    multicast: bool | None,
    keys: Path | None,
    insecure: bool,
    broadcast: str | None = None,
    group: str | None = None,
    interface: str | None = None,
) -> Link:
    """The ground station's link from its command-line options (exit 2 when unusable)."""
    check_swarm(swarm)
    return Link(
        swarm,
        zenoh_settings(connect, listen, multicast, broadcast, group, interface),
        packet_guard(keys, insecure, "ground"),
    )


def default_state_file(swarm: str) -> Path:
    """Where ``gs deploy`` remembers what it deployed to ``swarm``."""
    return user_state_dir() / f"gs-{swarm}.json"
