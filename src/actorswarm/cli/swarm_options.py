"""What every command that talks to a real swarm shares: its connection options (swarm
name, Zenoh endpoints, keys), declared once as :class:`LinkOptions` and put into each
ground-station command by :func:`link_options`, and turning them into a transport
configuration and a packet guard, with a clear error and exit status 2 when they are not
usable (:mod:`.swarm_setup`)."""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, TypeVar, get_type_hints

import typer

from actorswarm.cli.swarm_setup import check_swarm, packet_guard, user_state_dir, zenoh_settings
from actorswarm.security.guard import PacketGuard
from actorswarm.transport.zenoh_transport import ZenohSettings

if TYPE_CHECKING:
    from actorswarm.daemon.ground import GroundSession

__all__ = [
    "Link",
    "LinkOptions",
    "TimeoutOpt",
    "check_swarm",
    "default_state_file",
    "link_options",
    "packet_guard",
    "zenoh_settings",
]

R = TypeVar("R")

TimeoutOpt = Annotated[float, typer.Option(min=0.1, help="Seconds to wait for the swarm.")]


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


@dataclass(frozen=True, slots=True, kw_only=True)
class LinkOptions:
    """The connection options of every ground-station command, as the user gave them.

    Each field is declared here once, with its typer option (name, environment variable,
    help) and its default; :func:`link_options` makes them a command's options, in this
    order. The environment variables are also where a profile's settings arrive
    (:mod:`actorswarm.cli.profile`, whose keys are these fields' names)."""

    swarm: Annotated[
        str,
        typer.Option(envvar="ACTORSWARM_SWARM", help="The swarm's name (its Zenoh namespace)."),
    ] = "swarm"
    connect: Annotated[
        list[str] | None,
        typer.Option(
            metavar="ENDPOINT",
            envvar="ACTORSWARM_CONNECT",
            help="Zenoh endpoint to connect to (repeatable).",
        ),
    ] = None
    listen: Annotated[
        list[str] | None,
        typer.Option(
            metavar="ENDPOINT", envvar="ACTORSWARM_LISTEN", help="Zenoh endpoint to listen on."
        ),
    ] = None
    multicast: Annotated[
        bool | None,
        typer.Option(
            "--multicast/--no-multicast",
            envvar="ACTORSWARM_MULTICAST",
            help="Multicast scouting of peers on the mesh (either flag puts the command on "
            "the mesh: --no-multicast for listed peers).",
        ),
    ] = None
    broadcast: Annotated[
        str | None,
        typer.Option(
            envvar="ACTORSWARM_BROADCAST",
            help="How the swarm's broadcasts travel: multicast (the default unless --listen, "
            "--connect or --[no-]multicast is given: everything on --group) or mesh; every "
            "platform must say the same.",
        ),
    ] = None
    group: Annotated[
        str | None,
        typer.Option(
            envvar="ACTORSWARM_GROUP",
            help="The multicast group, ADDRESS:PORT (default 224.0.0.225:7448).",
        ),
    ] = None
    interface: Annotated[
        str | None,
        typer.Option(
            envvar="ACTORSWARM_INTERFACE",
            help="The network interface of the multicast group (wlan0; default: any).",
        ),
    ] = None
    keys: Annotated[
        Path | None,
        typer.Option(
            envvar="ACTORSWARM_KEYS",
            help="The swarm's key directory (default: the user's; see `keys init`).",
        ),
    ] = None
    insecure: Annotated[
        bool,
        typer.Option(
            "--insecure",
            envvar="ACTORSWARM_INSECURE",
            help="No packet authentication (trusted networks only).",
        ),
    ] = False

    def link(self) -> Link:
        """The link these options describe (a clear error and exit 2 when unusable)."""
        check_swarm(self.swarm)
        return Link(
            self.swarm,
            zenoh_settings(
                self.connect,
                self.listen,
                self.multicast,
                self.broadcast,
                self.group,
                self.interface,
            ),
            packet_guard(self.keys, self.insecure, "ground"),
        )


def link_options(command: Callable[..., R]) -> Callable[..., R]:
    """``command``, which takes one parameter annotated :class:`LinkOptions`, as a typer
    command with the connection options in that parameter's place.

    The contract: the returned function's signature (what typer reads) is ``command``'s
    with that parameter replaced by :class:`LinkOptions`' fields, each a keyword-only
    typer option with the field's name, default and annotation; every other parameter,
    the name and the docstring stay ``command``'s. Typer calls it with every option by
    keyword; it gathers the fields' values into one :class:`LinkOptions` and calls
    ``command`` with the rest of the values and that object. A command without exactly one
    such parameter, or with a parameter named as a field, is a ``TypeError`` at import."""
    own = inspect.signature(command, eval_str=True)
    slots = [p.name for p in own.parameters.values() if p.annotation is LinkOptions]
    names = [f.name for f in fields(LinkOptions)]
    if len(slots) != 1 or set(names) & set(own.parameters):
        raise TypeError(f"{command.__qualname__}: needs one LinkOptions parameter, no field")
    hints = get_type_hints(LinkOptions, include_extras=True)
    shared = [
        inspect.Parameter(
            f.name, inspect.Parameter.KEYWORD_ONLY, default=f.default, annotation=hints[f.name]
        )
        for f in fields(LinkOptions)
    ]
    params: list[inspect.Parameter] = []
    for p in own.parameters.values():
        # Keyword-only: typer passes every value by keyword, and so the order of the
        # parameters (the help's) need not follow Python's defaults-last rule.
        params.extend(shared if p.name in slots else [p.replace(kind=p.KEYWORD_ONLY)])

    @functools.wraps(command)
    def run(**values: Any) -> R:  # typer gives each value the type of its annotation
        conn = LinkOptions(**{name: values.pop(name) for name in names})
        return command(**values, **{slots[0]: conn})

    run.__signature__ = own.replace(parameters=params)  # type: ignore[attr-defined]
    run.__annotations__ = {p.name: p.annotation for p in params} | {"return": own.return_annotation}
    return run


def default_state_file(swarm: str) -> Path:
    """Where ``gs deploy`` remembers what it deployed to ``swarm``."""
    return user_state_dir() / f"gs-{swarm}.json"
