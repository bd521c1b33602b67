"""Ground-station commands and the platforms' replies (docs/design.md §4.2), and their codec.

Commands travel from the ground station (platform ID 0) to platforms as reliable application
messages on the urgent channel (topic :data:`TOPIC_COMMAND`), so they are retransmitted
until acknowledged and processed before swarm traffic. Replies come back the same way (topic
:data:`TOPIC_REPLY`). Every message is a msgspec struct of one tagged union; a body that does
not decode is refused with :class:`CommandError`, never crashes a platform.

A task script is deployed in chunks (:class:`DeployChunk`) so that a script of any allowed
size fits the radio's packets; each platform reassembles it, checks its SHA-256 and answers
:class:`DeployAck` — the ground station refuses ``start`` until every expected platform has
confirmed, unless forced.
"""

from __future__ import annotations

from typing import Annotated, Any

import msgspec
from msgspec import Meta

TOPIC_COMMAND = "gs.command"
TOPIC_REPLY = "gs.reply"
CHUNK_BYTES = 16_000

Name = Annotated[str, Meta(max_length=256)]
Sha = Annotated[str, Meta(min_length=64, max_length=64, pattern="^[0-9a-f]{64}$")]


class _Cmd(msgspec.Struct, frozen=True, tag=True, forbid_unknown_fields=True):
    """Base of every command and reply."""


class DeployChunk(_Cmd, frozen=True):
    """Part ``index`` (0-based) of ``total`` of the script whose SHA-256 is ``sha256``."""

    sha256: Sha
    index: Annotated[int, Meta(ge=0, le=1024)]
    total: Annotated[int, Meta(ge=1, le=1024)]
    data: bytes


#: Seconds since 1970 (UTC): a task's start on the clock the platforms share (GPS or NTP
#: time on robots). Bounded so that a float of any sender stays a usable time.
Instant = Annotated[float, Meta(ge=0.0, le=1e11)]


class Start(_Cmd, frozen=True, omit_defaults=True):
    """Start the deployed script ``sha256`` (its initial actors, or the new version).

    ``began`` is when the task started on the swarm's shared clock (UTC seconds), the same
    for every platform however late the command reaches it: a platform's plugins count the
    task's time from it (``ctx.task_start``). None (a ground station that gives none): each
    platform counts from its own receipt of the command."""

    sha256: Sha
    began: Instant | None = None


class Inject(_Cmd, frozen=True):
    """An event from the operator; ``actors`` restricts it to holders of those actors."""

    event: Name
    actors: list[Name] = []
    data: Any = None
    occasion: Annotated[str, Meta(max_length=64)] = ""


class Force(_Cmd, frozen=True):
    """Forced transition: every running actor (or only ``src``) switches to ``to`` now."""

    to: Name
    src: Name | None = None
    params: dict[Name, Annotated[str, Meta(max_length=1024)]] = {}


class ForceStart(_Cmd, frozen=True):
    actor: Name


class ForceStop(_Cmd, frozen=True):
    actor: Name


class Pause(_Cmd, frozen=True):
    actor: Name


class Activate(_Cmd, frozen=True):
    actor: Name


class Backup(_Cmd, frozen=True):
    """Snapshot the actors and plugin state to local storage and report it."""


class Status(_Cmd, frozen=True):
    """Report actors, master flag, epoch and incarnation."""


Command = (
    DeployChunk
    | Start
    | Inject
    | Force
    | ForceStart
    | ForceStop
    | Pause
    | Activate
    | Backup
    | Status
)


class DeployAck(_Cmd, frozen=True, omit_defaults=True):
    """The whole script arrived and hashes to ``sha256``; ``began``: the platform already
    runs it, in the task that began then (UTC seconds, :class:`Start`), which a ground
    station starting it again gives the platforms that have not started it."""

    sha256: Sha
    began: Instant | None = None


class Result(_Cmd, frozen=True):
    """The outcome of a command: ``ok``, and a message saying what happened or why not."""

    command: Name
    ok: bool
    message: Annotated[str, Meta(max_length=2048)] = ""


class StatusReply(_Cmd, frozen=True):
    actors: dict[Name, Name]  # actor -> running | sleeping
    master: bool
    epoch: int
    incarnation: int
    script: Annotated[str, Meta(max_length=64)] = ""
    #: Every loaded actor's control block (name, ID, status, priority, plugins, hardware,
    #: permission, task context, relations, statistics).
    acbs: dict[Name, Any] = {}
    #: Where the platform's vehicle is (x, y, z in metres, the mission frame), when it has
    #: one: what puts a real swarm on the operator's map.
    position: list[float] | None = None
    #: What the vehicle adapter says of itself when it says anything (a MAVLink vehicle:
    #: ``link`` up/lost, ``autopilot``, ``mode``, ``armed``, ``battery``, ``override``).
    vehicle: dict[Name, str | int | float | bool | None] = {}
    #: The roles the platform holds now (the collective core's arbitration, names sorted).
    #: Added in wire protocol 3: a ground station of an older build would refuse the whole
    #: reply for this field, so the protocol version says it and refuses the packet instead.
    roles: list[Name] = []
    #: When the task the platform runs began (UTC seconds, :class:`Start`); None: none.
    began: Instant | None = None
    #: The platform's own reading of the shared clock (UTC seconds) as it answered: what
    #: tells a ground station a platform whose clock is off (the task's clock needs them
    #: to agree). None: not known (a reply made without a time).
    clock: Instant | None = None


class BackupReply(_Cmd, frozen=True):
    generation: int
    size: int


Reply = DeployAck | Result | StatusReply | BackupReply


def outcome(reply: Reply, command: str) -> tuple[bool, str] | None:
    """What ``reply`` says of the platform's command named ``command`` (the command's class
    name, as :class:`Result` names it): ``(ok, message)``, or None for a reply to another."""
    if isinstance(reply, Result) and reply.command == command:
        return reply.ok, reply.message
    if isinstance(reply, BackupReply) and command == "Backup":
        return True, f"backup generation {reply.generation}, {reply.size} bytes"
    return None


_ENCODER = msgspec.msgpack.Encoder()
_COMMANDS: msgspec.msgpack.Decoder[Command] = msgspec.msgpack.Decoder(Command)
_REPLIES: msgspec.msgpack.Decoder[Reply] = msgspec.msgpack.Decoder(Reply)


class CommandError(ValueError):
    """A command or reply body that does not decode."""


def encode(message: Command | Reply) -> bytes:
    return _ENCODER.encode(message)


def decode_command(body: bytes) -> Command:
    try:
        return _COMMANDS.decode(body)
    except (msgspec.DecodeError, RecursionError, ValueError, TypeError) as exc:
        raise CommandError(f"not a ground-station command: {exc}") from None


def decode_reply(body: bytes) -> Reply:
    try:
        return _REPLIES.decode(body)
    except (msgspec.DecodeError, RecursionError, ValueError, TypeError) as exc:
        raise CommandError(f"not a platform reply: {exc}") from None


def chunks(script: bytes, sha256: str) -> list[DeployChunk]:
    """The deploy messages of ``script``."""
    parts = [script[i : i + CHUNK_BYTES] for i in range(0, max(len(script), 1), CHUNK_BYTES)]
    return [DeployChunk(sha256, i, len(parts), p) for i, p in enumerate(parts)]
