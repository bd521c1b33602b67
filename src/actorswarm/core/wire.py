"""Wire format: every packet the collective core sends or accepts, and its one codec.

Theory of operation
-------------------
A packet is an :class:`Envelope` (msgpack array): a versioned header — protocol version,
swarm ID, sender platform, sender incarnation, per-sender packet sequence, body type — then
the body, then an authentication tag (empty until a security layer fills it), followed by a
4-byte CRC-32 of all that: a packet damaged on the air is refused (reason ``checksum``)
instead of being taken at its word (a flipped incarnation would silence a peer for good).
The body is kept as raw msgpack in the envelope and decoded with the decoder of its type,
so a packet of a newer protocol version or an unknown type is refused before its body is
even looked at.

:func:`decode` is the only way untrusted bytes enter the core. It returns a valid
:class:`Packet` or raises :class:`WireError` — never anything else — whose ``reason`` says
which check failed (``oversized``, ``checksum``, ``malformed``, ``version``, ``swarm``,
``type``). All
numeric fields carry range constraints, so a decoded packet never holds a negative sequence
or a platform ID outside 0..65535.

Platform ID 0 is reserved for the ground station.
"""

from __future__ import annotations

import zlib
from collections.abc import Mapping, Sequence
from typing import Annotated, Any, Final

import msgspec
from msgspec import Meta, Struct

#: The wire format's version, in every packet's header: a packet of any other is refused
#: before its body is read (:class:`WireError` ``version``; a daemon's guard counts it as
#: malformed), so a swarm half upgraded says so instead of half working.
#: Raised whenever a message's fields change, the ground station's included (2:
#: ``BarrierRequest.renew``; 3: ``StatusReply.roles``; 4: the task's clock, ``Start.began``,
#: ``DeployAck.began``, ``StatusReply.began`` and ``.clock``; actorswarm.engine.commands).
PROTOCOL_VERSION: Final = 4
GROUND_STATION: Final = 0
MAX_PLATFORM: Final = 65535

PlatformId = Annotated[int, Meta(ge=0, le=MAX_PLATFORM)]
Counter = Annotated[int, Meta(ge=0, le=2**63 - 1)]
Key = Annotated[int, Meta(ge=0, le=2**31 - 1)]
Channel = Annotated[int, Meta(ge=0, le=2)]
Name = Annotated[str, Meta(max_length=256)]
Finite = Annotated[float, Meta(ge=-1e300, le=1e300)]

#: Reliable channels: ground-station traffic has a channel of its own that is sent and
#: processed before swarm traffic (docs/design.md §3.3, priorities); master-bound traffic has one
#: whose sequence numbers survive a change of master, so a message re-targeted to a master
#: that already had it is recognised as a duplicate.
URGENT: Final = 0
NORMAL: Final = 1
TO_MASTER: Final = 2
#: Not a channel of :class:`Data`: the stream label of bulletins in ``AppReceived.stream``.
BULLETIN_STREAM: Final = 3


class WireError(ValueError):
    """Bytes that are not a valid packet for this swarm. ``reason`` is a short machine tag."""

    def __init__(self, reason: str, detail: str) -> None:
        super().__init__(f"{reason}: {detail}")
        self.reason = reason
        self.detail = detail


class _Msg(Struct, frozen=True, array_like=True, forbid_unknown_fields=True):
    """Base of every message: immutable, positional on the wire.

    The containers of a roster chunk and a release are typed ``Sequence``/``Mapping``
    (they decode as lists and dicts): their receivers only read them, and strict type
    checking keeps it so, because a simulated swarm hands the receivers of one broadcast
    the same decoded body (:class:`~actorswarm.security.guard.VerdictMemo`)."""


# --- application payloads carried by reliable Data packets ---------------------------------


class BarrierRequest(_Msg, frozen=True, tag=1):
    """A participant asks to pass barrier ``key`` in its ``generation``.

    ``need`` maps each part of the barrier group to the number of participants it needs
    (a plain barrier has one part, 0); ``part`` is the one this request counts for. A need
    of :data:`NEED_ALL` means "every platform the master's policy counts" (all live members
    by default). ``bid`` orders candidates (lower wins); ``data`` is gathered by the master.
    ``timeout`` (seconds from the group's first request) and ``age`` (how long the request
    has been pending when sent, so a new master can keep the original start) are optional.
    ``epoch`` is the epoch the member followed when it asked: a firing decided in an older
    epoch cannot have counted this request (a rebooted platform never "completes" a firing
    that happened before it asked).

    A request counts for the generation it names and no other (docs/design.md §4), with
    one exception its requester asks for, ``renew`` below: a request the requester would
    make again at once for the next generation if this one were refused.
    """

    key: Key
    generation: Counter
    need: dict[int, Annotated[int, Meta(ge=-1, le=MAX_PLATFORM)]]
    part: Key = 0
    bid: Finite = 0.0
    data: Any = None
    timeout: Annotated[float, Meta(gt=0, le=1e9)] | None = None
    age: Annotated[float, Meta(ge=0, le=1e9)] = 0.0
    epoch: Counter = 0
    #: What the request was made for (e.g. one event occurrence). A late request for an
    #: occasion a firing already served is released as not chosen rather than left stale.
    occasion: Annotated[str, Meta(max_length=64)] = ""
    #: The master of ``epoch`` (0: unknown). Two masters may claim one epoch number (a
    #: rebooted platform that heard nobody's epoch): a master of the same epoch but another
    #: ID is another regime, whose firing this request may belong to.
    master: PlatformId = 0
    #: The requester asks again at once for the open generation when told this one is
    #: stale (the task engine does, for every candidacy of a transition). A master that
    #: would refuse it as stale counts it for the open generation instead when it alone
    #: fires that generation: a release to this platform alone, which no other platform can
    #: have passed, so nothing is lost for a later master to complete. Otherwise, and for a
    #: request without it, the master refuses as before.
    renew: bool = False


class BarrierStale(_Msg, frozen=True, tag=2):
    """Master to member: your request for ``generation`` is void; ``current`` is open now."""

    key: Key
    generation: Counter
    current: Counter


class ReleaseRecord(_Msg, frozen=True):
    """What a member remembers of the last release it passed (reported to a new master)."""

    key: Key
    generation: Counter
    part: Key
    index: Annotated[int, Meta(ge=0, le=MAX_PLATFORM)]
    size: Annotated[int, Meta(ge=0, le=MAX_PLATFORM)]
    outcome: Annotated[int, Meta(ge=0, le=2)]
    origin: Counter = 0
    #: The whole firing (platform -> (part, index)) when this member saw every entry of it.
    assignment: dict[PlatformId, tuple[Key, Annotated[int, Meta(ge=0, le=MAX_PLATFORM)]]] = {}
    #: The master that decided the firing (with ``origin``, its epoch, the firing's name).
    origin_master: PlatformId = 0
    #: Entries of the firing this member saw without seeing all of it (a master completing
    #: a predecessor's firing sends only what it adds): each names a candidate of the firing,
    #: but a platform it does not name may be one too.
    partial: dict[PlatformId, tuple[Key, Annotated[int, Meta(ge=0, le=MAX_PLATFORM)]]] = {}


class RoleClaim(_Msg, frozen=True, tag=4):
    """Member asks the master for ``role``; at most ``quota`` platforms may hold it."""

    role: Name
    quota: Annotated[int, Meta(ge=1, le=MAX_PLATFORM)]
    bid: Finite = 0.0


class RoleRelease(_Msg, frozen=True, tag=5):
    """Member gives ``role`` up (or withdraws its claim)."""

    role: Name


class RoleGrant(_Msg, frozen=True, tag=6):
    role: Name


class RoleDeny(_Msg, frozen=True, tag=7):
    """The quota is full; the claim stays queued and is granted when a holder goes."""

    role: Name
    holders: list[PlatformId]


class RoleRevoke(_Msg, frozen=True, tag=8):
    """The master takes ``role`` back (quota exceeded after a partition healed)."""

    role: Name


class Sync(_Msg, frozen=True, tag=9):
    """Master handshake: follow epoch ``epoch`` and report your state. ``bulletin`` is the
    first of the master's bulletins this member is a target of (0: unknown)."""

    epoch: Counter
    bulletin: Counter = 0


class Report(_Msg, frozen=True, tag=10):
    """Member's answer to :class:`Sync`: everything a new master needs to rebuild its state.

    ``epoch`` is the epoch it answers; a master ignores a report for another epoch.
    """

    epoch: Counter
    generations: dict[int, Counter]
    pending: list[BarrierRequest]
    released: list[ReleaseRecord]
    held: list[RoleClaim]
    claims: list[RoleClaim]


class AppMessage(_Msg, frozen=True, tag=11):
    """Opaque payload for the layers above the core (task engine, ground station)."""

    topic: Name
    body: bytes


Payload = (
    BarrierRequest
    | BarrierStale
    | RoleClaim
    | RoleRelease
    | RoleGrant
    | RoleDeny
    | RoleRevoke
    | Sync
    | Report
    | AppMessage
)

# --- packet bodies ------------------------------------------------------------------------


#: How many suspects a heartbeat names at most (a free probe for each), and how many roster
#: changes and successors it carries: bounded, so a heartbeat stays small at any swarm size.
MAX_SUSPECTS: Final = 32
MAX_CHANGES: Final = 16
MAX_SUCCESSION: Final = 16
#: How many platforms a master's heartbeat names as awaited by a barrier of all at most: it
#: names them only when so few are missing.
MAX_AWAITED: Final = 16


class Heartbeat(_Msg, frozen=True, tag=1):
    """Every heartbeat interval: who I am, whether I am master, whom I follow.

    ``count`` numbers the sender's scheduled heartbeats (a probe or an answer to one repeats
    the current count), so a receiver measures the loss from the gaps. ``suspects`` names
    the peers the sender suspects: a peer that finds itself listed answers at once (a free
    probe, docs/design.md §3.1).

    A star master's heartbeat also carries what its members need of its view: ``roster``,
    the version of its roster in this epoch, and ``size``, its member count; ``changes``,
    the last changes, the newest last (``(platform, incarnation)`` for a join,
    ``(platform, -1)`` for a leave), so a member one or a few versions behind catches up
    without asking; ``succession``, the next-lowest live IDs, in order, who take over
    without an election round when the master is lost; ``cadence``, the member heartbeat
    interval the master asks for (seconds, 0: ``heartbeat_interval``); ``interval_ms``, the
    master's own heartbeat interval in milliseconds (0: ``heartbeat_interval``; shorter
    under heavy loss; an integer, one byte on the wire when 0).

    A master's heartbeat (either mode) also names in ``awaited`` the platforms of its view a
    barrier of all still waits for, when at most :data:`MAX_AWAITED` are missing and the
    barrier has waited a first retry's time: a listed member whose request is on its way
    sends it again at once instead of at its next retry (a lost request otherwise waits out
    a retry delay that, on a shared channel, grows to seconds).
    """

    is_master: bool
    epoch: Counter
    master: PlatformId
    count: Counter = 0
    suspects: Annotated[list[PlatformId], Meta(max_length=MAX_SUSPECTS)] = []
    roster: Counter = 0
    size: Annotated[int, Meta(ge=0, le=MAX_PLATFORM)] = 0
    changes: Annotated[
        list[tuple[PlatformId, Annotated[int, Meta(ge=-1, le=2**63 - 1)]]],
        Meta(max_length=MAX_CHANGES),
    ] = []
    succession: Annotated[list[PlatformId], Meta(max_length=MAX_SUCCESSION)] = []
    cadence: Annotated[float, Meta(ge=0, le=3600)] = 0.0
    awaited: Annotated[list[PlatformId], Meta(max_length=MAX_AWAITED)] = []
    interval_ms: Annotated[int, Meta(ge=0, le=3_600_000)] = 0


class RosterRequest(_Msg, frozen=True, tag=6):
    """A star member whose roster is behind asks its master (unicast) for the whole roster
    of ``epoch``; ``version`` is the one it has (0: none)."""

    epoch: Counter
    version: Counter


class RosterChunk(_Msg, frozen=True, tag=7):
    """Part ``index`` of ``count`` of the master's roster (``members``: platform,
    incarnation) at ``version`` in ``epoch``; the master itself is not listed."""

    epoch: Counter
    version: Counter
    index: Annotated[int, Meta(ge=0, le=MAX_PLATFORM)]
    count: Annotated[int, Meta(ge=1, le=MAX_PLATFORM + 1)]
    members: Annotated[Sequence[tuple[PlatformId, Counter]], Meta(max_length=MAX_PLATFORM)]


class Bulletin(_Msg, frozen=True, tag=8):
    """One message from the master to every member, broadcast once (see core/delivery/bulletin.py).

    ``seq`` numbers the master's bulletins (per incarnation); ``floor`` is the lowest it
    still holds. ``skip`` names members it is not for (an event's origin); ``to``, on a
    retransmission, names the members still missing it (None on the first broadcast).
    """

    epoch: Counter
    seq: Annotated[int, Meta(ge=1, le=2**63 - 1)]
    floor: Annotated[int, Meta(ge=1, le=2**63 - 1)]
    message: AppMessage
    skip: Annotated[list[PlatformId], Meta(max_length=MAX_SUSPECTS)] = []
    to: Annotated[list[PlatformId], Meta(max_length=MAX_PLATFORM)] | None = None


class BulletinAck(_Msg, frozen=True, tag=9):
    """A member has every bulletin of ``dst`` (in ``dst_incarnation``) up to ``seq``."""

    dst: PlatformId
    dst_incarnation: Counter
    seq: Counter


class Data(_Msg, frozen=True, tag=2):
    """One reliable message on the stream (sender, sender incarnation, ``dst``, ``channel``).

    ``floor`` is the lowest sequence the sender still holds: anything below it was delivered
    or abandoned, so a receiver never waits for it. ``epoch`` is the sender's master epoch.
    """

    dst: PlatformId
    channel: Channel
    seq: Annotated[int, Meta(ge=1, le=2**63 - 1)]
    floor: Annotated[int, Meta(ge=1, le=2**63 - 1)]
    epoch: Counter
    payload: Payload


class Ack(_Msg, frozen=True, tag=3):
    """Cumulative acknowledgement: every message up to ``seq`` of that stream was delivered."""

    dst: PlatformId
    dst_incarnation: Counter
    channel: Channel
    seq: Counter


class ReleaseEntry(_Msg, frozen=True):
    """One candidate's share of a release: ``index`` 1..size within its part (0: not chosen)."""

    platform: PlatformId
    part: Key
    index: Annotated[int, Meta(ge=0, le=MAX_PLATFORM)]
    data: Any = None


class Release(_Msg, frozen=True, tag=4):
    """Master releases barrier ``key``/``generation``: one broadcast for every participant
    (a packet that names one platform besides the master goes to that platform alone).

    Retransmissions carry only the entries of candidates that have not acknowledged.
    ``outcome`` is :data:`COMPLETE` or :data:`TIMEOUT`; ``sizes`` maps part to the number
    chosen; ``gathered`` is the data every chosen participant attached to its request.
    ``origin`` is the epoch and ``origin_master`` the ID of the master that decided the
    firing (a later master that completes it keeps both), so two partitions' firings of one
    generation stay apart, even when both sides' masters claimed the same epoch number.
    ``total`` is the number of entries of the whole firing: a member that finds them all in
    one packet knows the complete assignment and reports it to any later master. It is 0
    when the sender does not hold the whole firing (a master completing a predecessor's
    firing from reports resends only the entries it completes).
    """

    epoch: Counter
    key: Key
    generation: Counter
    outcome: Annotated[int, Meta(ge=0, le=2)]
    sizes: Mapping[int, Annotated[int, Meta(ge=0, le=MAX_PLATFORM)]]
    entries: Sequence[ReleaseEntry]
    gathered: Sequence[tuple[PlatformId, Any]] = []
    origin: Counter = 0
    total: Annotated[int, Meta(ge=0, le=MAX_PLATFORM)] = 0
    origin_master: PlatformId = 0


class ReleaseAck(_Msg, frozen=True, tag=5):
    dst: PlatformId
    epoch: Counter
    key: Key
    generation: Counter


Body = (
    Heartbeat
    | Data
    | Ack
    | Release
    | ReleaseAck
    | RosterRequest
    | RosterChunk
    | Bulletin
    | BulletinAck
)

COMPLETE: Final = 1
TIMEOUT: Final = 2
NEED_ALL: Final = -1


class Envelope(_Msg, frozen=True):
    """The header and the still-encoded body; what the auth tag covers is ``header+body``."""

    version: Annotated[int, Meta(ge=0, le=255)]
    swarm: Annotated[str, Meta(max_length=64)]
    sender: PlatformId
    incarnation: Counter
    seq: Counter
    type: Annotated[int, Meta(ge=0, le=255)]
    body: msgspec.Raw
    auth: Annotated[bytes, Meta(max_length=128)] = b""


class Packet(Struct, frozen=True):
    """A decoded, validated packet: header fields plus a typed body."""

    swarm: str
    sender: int
    incarnation: int
    seq: int
    body: Body
    auth: bytes = b""

    @property
    def type_name(self) -> str:
        return type(self.body).__name__


_BODY_TYPES: dict[int, type[Body]] = {
    1: Heartbeat,
    2: Data,
    3: Ack,
    4: Release,
    5: ReleaseAck,
    6: RosterRequest,
    7: RosterChunk,
    8: Bulletin,
    9: BulletinAck,
}
_TYPE_OF: dict[type[Any], int] = {cls: tag for tag, cls in _BODY_TYPES.items()}
_ENVELOPE = msgspec.msgpack.Decoder(Envelope)
_BODY_DECODERS = {tag: msgspec.msgpack.Decoder(cls) for tag, cls in _BODY_TYPES.items()}
_ENCODER = msgspec.msgpack.Encoder()
DEFAULT_MAX_BYTES: Final = 60_000


def encode(
    *,
    swarm: str,
    sender: int,
    incarnation: int,
    seq: int,
    body: Body,
    auth: bytes = b"",
) -> bytes:
    """Encode one packet (bodies are untagged inside: the header's ``type`` names them)."""
    raw = msgspec.Raw(_ENCODER.encode(body))
    env = Envelope(
        version=PROTOCOL_VERSION,
        swarm=swarm,
        sender=sender,
        incarnation=incarnation,
        seq=seq,
        type=_TYPE_OF[type(body)],
        body=raw,
        auth=auth,
    )
    frame = _ENCODER.encode(env)
    return frame + zlib.crc32(frame).to_bytes(4, "big")


def decode(data: bytes, *, swarm: str | None = None, max_bytes: int = DEFAULT_MAX_BYTES) -> Packet:
    """Decode untrusted bytes into a :class:`Packet`, or raise :class:`WireError`.

    When ``swarm`` is given, packets of another swarm are refused (reason ``swarm``). The
    same as :func:`open_frame` then :func:`decode_body`.
    """
    return decode_body(open_frame(data, swarm=swarm, max_bytes=max_bytes))


def open_frame(
    data: bytes, *, swarm: str | None = None, max_bytes: int = DEFAULT_MAX_BYTES
) -> Envelope:
    """The first half of :func:`decode`: size, CRC-32, header, protocol version, swarm and a
    known body type are checked; the body stays encoded (:class:`WireError` on any failure).

    A security layer checks the tag here, over the raw bytes (:func:`covered`), so a forged
    packet costs no body decode.
    """
    if len(data) > max_bytes:
        raise WireError("oversized", f"{len(data)} bytes > limit {max_bytes}")
    env = _unframe(data)
    if env.version != PROTOCOL_VERSION:
        raise WireError("version", f"protocol version {env.version}, expected {PROTOCOL_VERSION}")
    if swarm is not None and env.swarm != swarm:
        raise WireError("swarm", f"packet of swarm {env.swarm!r}, this is {swarm!r}")
    if env.type not in _BODY_DECODERS:
        raise WireError("type", f"unknown packet type {env.type}")
    return env


def decode_body(env: Envelope) -> Packet:
    """The second half of :func:`decode`: the body of an envelope :func:`open_frame`
    accepted, decoded and validated once (:class:`WireError` ``malformed`` or ``type``)."""
    decoder = _BODY_DECODERS.get(env.type)
    if decoder is None:
        raise WireError("type", f"unknown packet type {env.type}")
    try:
        body = decoder.decode(env.body)
    except (msgspec.DecodeError, RecursionError, ValueError, TypeError) as exc:
        raise WireError("malformed", f"bad {_BODY_TYPES[env.type].__name__} body: {exc}") from None
    return Packet(
        swarm=env.swarm,
        sender=env.sender,
        incarnation=env.incarnation,
        seq=env.seq,
        body=body,
        auth=env.auth,
    )


def _unframe(data: bytes) -> Envelope:
    """Check the frame's CRC-32 and decode its envelope (WireError on any failure)."""
    if len(data) < 5:
        raise WireError("malformed", f"{len(data)} bytes is too short for a packet")
    frame, check = data[:-4], data[-4:]
    if zlib.crc32(frame).to_bytes(4, "big") != check:
        raise WireError("checksum", "frame check failed: the packet was damaged in transit")
    try:
        return _ENVELOPE.decode(frame)
    except (msgspec.DecodeError, RecursionError, ValueError, TypeError) as exc:
        raise WireError("malformed", f"bad header: {exc}") from None


# --- the authentication slot ----------------------------------------------------------------
#
# ``auth`` is the envelope's last field, and msgpack writes bytes shorter than 256 (the slot
# holds at most 128) as ``0xc4 <length> <bytes>``. So a packet as the core encodes it ends
# with ``0xc4 0x00`` and its CRC, and the tag can be put in (and taken out) by slicing, with
# no decode and no re-encode: the tag covers exactly the frame the core made.

_EMPTY_AUTH: Final = b"\xc4\x00"


def covered(data: bytes, env: Envelope) -> bytes:
    """What the tag of the packet ``data`` (whose envelope :func:`open_frame` gave as
    ``env``) covers: the frame as its sender's core made it, with an empty ``auth`` slot.

    Bytes whose slot is not written the way :func:`seal_frame` writes it give bytes no genuine tag
    covers (the check then fails, as it should)."""
    slot = 2 + len(env.auth)
    return data[: len(data) - 4 - slot] + _EMPTY_AUTH


def unsealed_frame(data: bytes) -> bytes:
    """The frame of ``data`` (a packet as :func:`encode` made it, its ``auth`` slot empty):
    what a tag over the packet covers. Raises :class:`ValueError` for bytes that are not
    such a packet (a bug of the caller, not something from the network): only the CRC and
    the slot are looked at."""
    frame = data[:-4]
    if len(data) < 7 or zlib.crc32(frame).to_bytes(4, "big") != data[-4:]:
        raise ValueError("cannot seal bytes that are not a packet: frame check failed")
    if frame[-2:] != _EMPTY_AUTH:
        raise ValueError("cannot seal a packet whose auth slot is not empty")
    return frame


def seal_frame(frame: bytes, auth: bytes) -> bytes:
    """The packet of :func:`unsealed_frame`'s ``frame`` with ``auth`` in its slot, framed
    with its CRC-32 (the same bytes :func:`encode` would write with that ``auth``)."""
    if len(auth) > 128:
        raise ValueError(f"an auth slot holds at most 128 bytes, not {len(auth)}")
    sealed = frame[:-2] + b"\xc4" + bytes((len(auth),)) + auth
    return sealed + zlib.crc32(sealed).to_bytes(4, "big")


def signed_part(data: bytes) -> bytes:
    """The bytes an authentication tag covers (:func:`covered` of ``data``); raises
    :class:`WireError` on bytes that are not an envelope."""
    return covered(data, _unframe(data))
