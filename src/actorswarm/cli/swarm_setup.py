"""Turning the options of a command that talks to a real swarm into a packet guard and a
Zenoh configuration, with a clear error on stderr and exit status 2 when they are not
usable. Free of typer, so ``actorswarm daemon`` can use it without loading the rest of the
command line (:mod:`actorswarm.cli.daemon_start`); the typer options themselves are in
:mod:`actorswarm.cli.swarm_options`."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Literal

from actorswarm.security.guard import PacketGuard
from actorswarm.transport.zenoh_transport import (
    DEFAULT_GROUP,
    LEASE_MS,
    RELAY_LEASE_MS,
    ZenohSettings,
    key_prefix,
)

__all__ = [
    "busy_endpoint",
    "check_swarm",
    "default_daemon_state",
    "packet_guard",
    "refuse",
    "user_state_dir",
    "zenoh_settings",
]


def refuse(message: str) -> SystemExit:
    """Print ``message`` on stderr; the exit (status 2) for the caller to raise."""
    print(message, file=sys.stderr, flush=True)
    return SystemExit(2)


def packet_guard(
    keys: Path | None, insecure: bool, role: Literal["platform", "ground"]
) -> PacketGuard:
    """The packet guard for ``role``, or a clear error and exit 2 when the keys are not
    usable."""
    from actorswarm.security import KeyFileError, default_key_dir, load_keys

    if insecure:
        print("WARNING: --insecure: packets are not authenticated", file=sys.stderr, flush=True)
        return PacketGuard.insecure()
    directory = keys or default_key_dir()
    try:
        loaded = load_keys(directory, need_private=role == "ground")
    except KeyFileError as exc:
        # The key module's message already says how to create the keys; add only what the
        # role does with them.
        then = (
            "a platform needs swarm.key and ground_station.pub from the ground station's key "
            "directory"
            if role == "platform"
            else "then copy swarm.key and ground_station.pub to every platform"
        )
        raise refuse(f"{exc}\n{then}, or run with --insecure (trusted networks only)") from None
    return PacketGuard.from_keys(loaded, role=role)


def zenoh_settings(
    connect: list[str] | None,
    listen: list[str] | None,
    multicast: bool | None,
    broadcast: str | None = None,
    group: str | None = None,
    interface: str | None = None,
    lease: float | None = None,
    relay: bool = False,
) -> ZenohSettings:
    """The Zenoh settings of these options, or a clear error and exit 2. ``multicast``
    (scouting) None: on for the mesh, off on a multicast group (which refuses it);
    ``lease`` in seconds (None: :data:`LEASE_MS`, :data:`RELAY_LEASE_MS` for a relay);
    ``relay``: forward for the others (multi-hop, a daemon's option).

    ``broadcast`` None chooses: the multicast group (a broadcast sent once, as a radio
    does), unless endpoints, scouting (``--multicast`` or ``--no-multicast``) or relaying
    are given, which are the mesh's; a group chosen so, with neither ``group`` nor
    ``interface`` named, falls back to the mesh where it cannot be opened
    (:attr:`ZenohSettings.fallback`)."""
    mesh_asked = bool(listen or connect) or multicast is not None or relay
    default_lease = RELAY_LEASE_MS if relay else LEASE_MS
    chosen = broadcast or ("mesh" if mesh_asked else "multicast")
    if chosen == "mesh" and (group is not None or interface is not None):
        raise refuse(
            "--group and --interface are the multicast group's: give --broadcast multicast"
            + (
                " (the mesh is chosen by --listen, --connect, --[no-]multicast or --relay)"
                if broadcast is None
                else ""
            )
        )
    try:
        return ZenohSettings(
            listen=tuple(listen or ()),
            connect=tuple(connect or ()),
            multicast=multicast if multicast is not None else chosen == "mesh",
            broadcast=chosen,
            group=group or DEFAULT_GROUP,
            interface=interface,
            lease_ms=round(lease * 1000) if lease is not None else default_lease,
            relay=relay,
            # Only a group nobody asked for: a named group or interface is meant.
            fallback=broadcast is None
            and group is None
            and interface is None
            and chosen == "multicast",
        )
    except ValueError as exc:
        raise refuse(str(exc)) from None


def check_swarm(swarm: str) -> None:
    """Exit 2 with the reason when ``swarm`` cannot be a swarm's name."""
    try:
        key_prefix(swarm)
    except ValueError as exc:
        raise refuse(str(exc)) from None


def busy_endpoint(endpoint: str) -> str | None:
    """Why this machine cannot listen on the Zenoh ``endpoint`` (``tcp/HOST:PORT``,
    ``udp/HOST:PORT``; others are not checked), one line; None when it can (at the moment
    of asking: another process may still take it before Zenoh does)."""
    import socket

    proto, _, rest = endpoint.partition("/")
    rest = rest.split("#")[0].split("?")[0]
    host, sep, port_text = rest.rpartition(":")
    if proto not in ("tcp", "udp") or not sep or not port_text.isdigit() or int(port_text) == 0:
        return None
    host = host.strip("[]")
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    kind = socket.SOCK_STREAM if proto == "tcp" else socket.SOCK_DGRAM
    try:
        with socket.socket(family, kind) as sock:
            if proto == "tcp":
                # As a listener does: a port in TIME_WAIT is free, one listened on is not.
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            sock.bind((host, int(port_text)))
    except OSError as exc:
        if exc.errno in (None, 0) or isinstance(exc, socket.gaierror):
            return None  # a name Zenoh resolves itself: let it say what is wrong
        return f"cannot listen on {endpoint}: {exc.strerror or exc}"
    return None


def user_state_dir() -> Path:
    """The user's state directory for actorswarm: ``$XDG_STATE_HOME/actorswarm``, or
    ``~/.local/state/actorswarm``."""
    import os

    base = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(base) / "actorswarm"


def default_daemon_state(swarm: str, platform: int) -> Path:
    """Where a daemon keeps its state without ``--state-dir``: under the user's state
    directory, per swarm and platform (not in the working directory, which may be a
    checkout)."""
    return user_state_dir() / swarm / f"platform-{platform}"
