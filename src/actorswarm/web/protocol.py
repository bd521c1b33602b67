"""What the page may ask of the server over the WebSocket, and its one codec.

Every message from the page is one JSON object whose ``op`` names the request; ``id`` is
the page's own label, echoed in the outcome so it can tell its commands' results from
other operators'. :func:`decode` turns the text into one of the frozen structs below or
raises :class:`ProtocolError` saying what was wrong — text from a browser is untrusted, and
a bad request must cost the operator one error line, never the server.

Platform lists are written as on the command line (``1-4,7``); None means every platform
heard. What the server sends back is described in :mod:`actorswarm.web.source`.
"""

from __future__ import annotations

from typing import Annotated

import msgspec
from msgspec import Meta

from actorswarm.dsl.parser import DEFAULT_MAX_BYTES

__all__ = [
    "Activate",
    "Backup",
    "Check",
    "Command",
    "Deploy",
    "Event",
    "Force",
    "Inspect",
    "Pause",
    "Play",
    "ProtocolError",
    "Request",
    "Seek",
    "Speed",
    "Start",
    "StartActor",
    "StopActor",
    "decode",
]

Name = Annotated[str, Meta(min_length=1, max_length=256)]
Ids = Annotated[str, Meta(max_length=4096)] | None
Label = Annotated[str, Meta(max_length=64)]
Script = Annotated[str, Meta(max_length=DEFAULT_MAX_BYTES)]


class _Op(msgspec.Struct, frozen=True, kw_only=True, tag_field="op", forbid_unknown_fields=True):
    id: Label = ""


class Check(_Op, frozen=True, kw_only=True, tag="check"):
    """Check a script without deploying it."""

    script: Script
    name: Name = "uploaded.xml"


class Deploy(_Op, frozen=True, kw_only=True, tag="deploy"):
    """Check ``script`` and, when it is valid, send it to ``platforms``."""

    script: Script
    name: Name = "uploaded.xml"
    platforms: Ids = None


class Start(_Op, frozen=True, kw_only=True, tag="start"):
    """Start the script deployed last (``force``: without every confirmation)."""

    force: bool = False


class Event(_Op, frozen=True, kw_only=True, tag="event"):
    """Inject event ``name``; ``actors`` restricts it to the holders of those actors."""

    name: Name
    platforms: Ids = None
    actors: list[Name] = []


class Force(_Op, frozen=True, kw_only=True, tag="force"):
    """Forced transition to ``to`` of the holders of ``src`` (any actor when None)."""

    to: Name
    src: Name | None = None
    platforms: Ids = None
    params: dict[Name, Annotated[str, Meta(max_length=1024)]] = {}


class Pause(_Op, frozen=True, kw_only=True, tag="pause"):
    actor: Name
    platforms: Ids = None


class Activate(_Op, frozen=True, kw_only=True, tag="activate"):
    actor: Name
    platforms: Ids = None


class StartActor(_Op, frozen=True, kw_only=True, tag="start_actor"):
    """Forced start of ``actor``."""

    actor: Name
    platforms: Ids = None


class StopActor(_Op, frozen=True, kw_only=True, tag="stop_actor"):
    """Forced stop of ``actor``."""

    actor: Name
    platforms: Ids = None


class Backup(_Op, frozen=True, kw_only=True, tag="backup"):
    platforms: Ids = None


class Speed(_Op, frozen=True, kw_only=True, tag="speed"):
    """The simulator's pace: virtual seconds per wall second."""

    speed: Annotated[float, Meta(gt=0.0, le=100.0)]


class Play(_Op, frozen=True, kw_only=True, tag="play"):
    """A replay: play (``playing``) or pause."""

    playing: bool


class Seek(_Op, frozen=True, kw_only=True, tag="seek"):
    """A replay: go to time ``t`` (seconds of the recording)."""

    t: Annotated[float, Meta(ge=0.0, le=1e9)]


class Inspect(_Op, frozen=True, kw_only=True, tag="inspect"):
    """Every actor control block of ``platform``; answered to the asking page only."""

    platform: Annotated[int, Meta(ge=1, le=65535)]


#: The requests that go to the swarm (through the ground station) or change the run.
Command = (
    Check
    | Deploy
    | Start
    | Event
    | Force
    | Pause
    | Activate
    | StartActor
    | StopActor
    | Backup
    | Speed
    | Play
    | Seek
)
Request = Command | Inspect

_DECODER: msgspec.json.Decoder[Request] = msgspec.json.Decoder(Request)


class ProtocolError(ValueError):
    """A message from the page that is not a request this server understands."""


def decode(text: str | bytes) -> Request:
    """The request in ``text``, or :class:`ProtocolError` naming what is wrong."""
    try:
        return _DECODER.decode(text)
    except msgspec.ValidationError as exc:
        raise ProtocolError(f"bad request: {exc}") from None
    except (msgspec.DecodeError, RecursionError, ValueError) as exc:
        raise ProtocolError(f"not a JSON request: {exc}") from None
