"""Events the collective core hands to the layers above it (task engine, hosts, tests).

Every event is a frozen, slotted, keyword-only dataclass. A host takes them, with the
packets to send, from :meth:`actorswarm.core.node.Node.ready` after each
``receive_packet``/``tick``/request call.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

LeaveReason = Literal["timeout", "suspected", "restarted"]
Outcome = Literal["complete", "timeout"]


@dataclass(frozen=True, slots=True, kw_only=True)
class MemberJoined:
    """``platform`` (in its ``incarnation``) entered this platform's view."""

    platform: int
    incarnation: int


@dataclass(frozen=True, slots=True, kw_only=True)
class MemberLeft:
    """``platform`` left the view: heartbeats stopped, or it rebooted (a new incarnation)."""

    platform: int
    incarnation: int
    reason: LeaveReason


@dataclass(frozen=True, slots=True, kw_only=True)
class MasterChanged:
    """This platform now follows ``master`` in ``epoch`` (``master`` is None: no master)."""

    master: int | None
    epoch: int


@dataclass(frozen=True, slots=True, kw_only=True)
class BecameMaster:
    """This platform claimed the master role in ``epoch`` (the handshake begins)."""

    epoch: int


@dataclass(frozen=True, slots=True, kw_only=True)
class SteppedDown:
    """This platform gave up the master role to ``to`` (a lower ID that is master too)."""

    epoch: int
    to: int


@dataclass(frozen=True, slots=True, kw_only=True)
class HandshakeComplete:
    """Every member in the master's view reported its state: the master's state is rebuilt."""

    epoch: int
    members: int


@dataclass(frozen=True, slots=True, kw_only=True)
class BarrierReleased:
    """This platform passed barrier ``key``/``generation``.

    ``chosen`` is False when more candidates asked than the barrier needed and this one was
    not picked (it stays where it is). ``index`` is 1..``size`` within ``part`` for a chosen
    participant; ``data`` is what the master scattered to it; ``gathered`` is every chosen
    participant's request data.
    """

    key: int
    generation: int
    outcome: Outcome
    chosen: bool
    part: int
    index: int
    size: int
    data: Any
    gathered: tuple[tuple[int, Any], ...]


@dataclass(frozen=True, slots=True, kw_only=True)
class BarrierStaleNotice:
    """The master refused a request of an old ``generation``; ``current`` is the open one."""

    key: int
    generation: int
    current: int


@dataclass(frozen=True, slots=True, kw_only=True)
class BarrierFired:
    """Master only: it released ``key``/``generation`` to ``chosen`` (platform -> part, index)."""

    key: int
    generation: int
    epoch: int
    outcome: Outcome
    chosen: dict[int, tuple[int, int]]
    not_chosen: tuple[int, ...]
    completion: bool


@dataclass(frozen=True, slots=True, kw_only=True)
class RoleGranted:
    role: str


@dataclass(frozen=True, slots=True, kw_only=True)
class RoleDenied:
    """The quota of ``role`` is full (held by ``holders``); the claim waits for a free slot."""

    role: str
    holders: tuple[int, ...]


@dataclass(frozen=True, slots=True, kw_only=True)
class RoleRevoked:
    role: str


@dataclass(frozen=True, slots=True, kw_only=True)
class DeliveryFailed:
    """A reliable message to ``dst`` (None: the master) was not acknowledged by its deadline."""

    dst: int | None
    kind: str
    reason: str


@dataclass(frozen=True, slots=True, kw_only=True)
class AppReceived:
    """A reliable application message, delivered exactly once and in order per sender."""

    sender: int
    topic: str
    body: bytes
    #: (sender incarnation, channel, sequence): identifies one message of one stream, so a
    #: duplicate is detectable; None for a message a platform sent itself.
    stream: tuple[int, int, int] | None = None


CoreEvent = (
    MemberJoined
    | MemberLeft
    | MasterChanged
    | BecameMaster
    | SteppedDown
    | HandshakeComplete
    | BarrierReleased
    | BarrierStaleNotice
    | BarrierFired
    | RoleGranted
    | RoleDenied
    | RoleRevoked
    | DeliveryFailed
    | AppReceived
)
