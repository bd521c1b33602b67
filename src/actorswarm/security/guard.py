"""The packet guard: authentication and replay protection between the core and a transport.

Theory of operation
-------------------
A host puts a :class:`PacketGuard` between its core (or ground station) and its transport
(docs/design.md §2), so every transport gets the same protection:

* every outgoing packet goes through :meth:`PacketGuard.seal`, which fills the envelope's
  ``auth`` slot: an HMAC-SHA256 tag made with the swarm key over the frame exactly as the
  core encoded it (with its empty slot, :func:`~actorswarm.core.wire.covered`), 32 bytes;
  and, for the ground station's own packets (sender 0), an Ed25519 signature by the ground
  station's private key over the same bytes: 32 + 64 bytes. The slot is the envelope's last
  field, so the tag goes in by slicing: one HMAC and one CRC per packet, no re-encoding;
* every incoming packet goes through :meth:`PacketGuard.check`, which checks the frame and
  the tag over the raw bytes, then the replay window, and decodes the body last — a forged
  packet never costs a body decode — returning the decoded
  :class:`~actorswarm.core.wire.Packet` for the core's ``receive_packet`` only when it passed
  every check, and otherwise counting the refusal in :attr:`PacketGuard.rejected`.

Checks, in order (the reason counted when one fails):

``malformed``
    the bytes are not a packet (any :class:`~actorswarm.core.wire.WireError`: damaged frame,
    bad header, oversized, unknown version or type; or, checked last, a bad body);
``unauthenticated``
    the ``auth`` slot is empty;
``bad_tag``
    the HMAC does not verify (wrong swarm key, altered packet) or the slot has the wrong
    length for its sender (a platform's packet carries exactly the 32-byte tag);
``unsigned_operator``
    a packet from the ground station (sender 0) without a signature: what a captured robot,
    which knows the swarm key but not the operator's private key, would send;
``bad_signature``
    the signature of a ground-station packet does not verify with the configured public key;
``replay``
    the packet was accepted before, or is too old to tell (see below).

The cheap HMAC is checked before the signature, so bytes from outside the swarm never cost a
signature verification. Only a packet that passed every check changes the replay state: a
forged packet cannot move a window or raise an incarnation.

Replay protection
-----------------
The core numbers packets per sender: :class:`~actorswarm.core.node.Node` and
:class:`~actorswarm.ground.station.GroundStation` increment one counter for *every* packet
they encode — heartbeats, acknowledgements, releases, and each retransmission of reliable
data, which is re-encoded with a fresh number — so ``(sender, incarnation, seq)`` never
repeats and any repeat is a replay. The guard keeps, per sender, the highest incarnation it
accepted and, within it, a sliding window of the last :data:`DEFAULT_WINDOW` sequence
numbers (a bitmap under the highest seq accepted). A packet of an older incarnation, a seq
already marked, or a seq below the window is a ``replay``; a newer incarnation starts a new
window. The window, rather than "seq must grow", is there because packets are reordered on
the way (broadcast and unicast take different routes; radio jitter): a late genuine packet
inside the window is still accepted, once. A genuine packet later than the whole window is
refused; if it carried reliable data, the core's retransmission (a new seq) brings it.
The tag covers the bytes as sent: another msgpack encoding of the same values fails it.

Incarnations must grow on every restart of a sender (the core relies on that too): a sender
restarted with the same incarnation starts its seq again at 1 and is refused as a replay
until its seq passes where it was. The ground station is a sender like any other.

Threat model
------------
Protected:

* **forgery** — a packet made or altered without the swarm key fails the HMAC;
* **wrong key** — a platform of another swarm key (or none) is not heard, nor hears us;
* **replay** — a recorded packet sent again, in its incarnation or after a restart of its
  sender, is refused (with the limit below);
* **operator impersonation** — a captured or compromised robot holds the swarm key but not
  the ground station's private key, so it cannot send packets as the ground station
  (commands, task scripts, forced transitions are only accepted from sender 0, signed).

Not protected:

* **confidentiality** — packets are authenticated, not encrypted: anyone in radio range
  reads task scripts, positions and commands;
* **a captured robot speaking as itself** or as another platform (the swarm key is shared):
  it can lie in heartbeats, claim mastership, bid in barriers; rotate the swarm key
  (``actorswarm keys init --force``) to shut it out;
* **denial of service** — jamming, flooding (each forged packet still costs a CRC, a header
  decode and an HMAC, never a body decode), or dropping packets;
* **replay to a receiver without state** — a receiver that just started knows nothing of a
  sender until it accepts one of its packets, so a recording of that sender's current (or an
  older) incarnation can be replayed to it, each packet once, until the sender's genuine
  traffic moves the window past it. A host narrows this by keeping
  :meth:`PacketGuard.replay_snapshot` in its state directory and handing it to
  :meth:`PacketGuard.restore_replay` on restart. The core ignores unicast data addressed to
  another platform, so replaying one platform's packet to another does no harm.

The guard is sans-IO like the core: bytes and ``now`` in, a packet or ``None`` out; it reads
no clock and no file (keys come from :mod:`actorswarm.security.keys`).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping
from typing import TYPE_CHECKING, Final, Literal

from actorswarm.core import wire
from actorswarm.core.digest import HmacSha256, equal
from actorswarm.core.wire import GROUND_STATION, Packet, WireError
from actorswarm.security.ed25519 import PublicKey
from actorswarm.security.keys import Keys, fingerprint, public_key_fingerprint

if TYPE_CHECKING:
    from cryptography.hazmat.primitives.asymmetric.ed25519 import (
        Ed25519PrivateKey,
        Ed25519PublicKey,
    )

Role = Literal["platform", "ground"]

TAG_BYTES: Final = 32
SIGNATURE_BYTES: Final = 64
#: Sequence numbers per sender remembered below the highest one accepted.
DEFAULT_WINDOW: Final = 1024
#: Every reason :attr:`PacketGuard.rejected` counts, in the order the checks run.
REASONS: Final = (
    "malformed",
    "unauthenticated",
    "bad_tag",
    "unsigned_operator",
    "bad_signature",
    "replay",
)
_MIN_KEY_BYTES: Final = 16


#: How many claimed senders :attr:`PacketGuard.refused_from` keeps per reason.
_MAX_NAMED: Final = 256


class _Window:
    """Which seqs of one sender incarnation were accepted: bit ``k`` of ``seen`` is
    ``top - k``. Everything below ``top - size + 1`` counts as seen."""

    __slots__ = ("heard", "incarnation", "seen", "size", "top")

    def __init__(self, incarnation: int, seq: int, size: int, heard: float) -> None:
        self.incarnation = incarnation
        self.top = seq
        self.seen = 1
        self.size = size
        self.heard = heard

    def fresh(self, seq: int) -> bool:
        if seq > self.top:
            return True
        back = self.top - seq
        return back < self.size and not (self.seen >> back) & 1

    def mark(self, seq: int) -> None:
        if seq > self.top:
            shift = seq - self.top
            # A big jump empties the window (and never builds a huge integer).
            self.seen = 1 if shift >= self.size else ((self.seen << shift) | 1) & self.mask
            self.top = seq
        else:
            self.seen |= 1 << (self.top - seq)

    @property
    def mask(self) -> int:
        return (1 << self.size) - 1


class VerdictMemo:
    """The frame and authentication verdicts of up to ``size`` packets checked, shared
    by guards that hold the same keys and size limit (a simulated swarm's, where every
    receiver of a broadcast checks the very same bytes).

    What it keeps is a pure function of the bytes and the keys — the envelope, or the
    reason the tag or signature failed — so a guard that finds the bytes here skips the
    CRC, the header decode, the HMAC and any signature check and ends with the same result
    it would have computed. The replay window stays each guard's own, and so does the
    decoded packet, but for the bodies its receivers only read (:func:`shareable`): a
    roster chunk or a release is decoded by the first guard that accepts it and handed to
    the others as it is — at 10 000 platforms, decoding each release chunk once per
    receiver was most of the run. A daemon's guard has none: it never checks the same
    bytes twice.
    """

    __slots__ = ("_packets", "_size", "_verdicts")

    def __init__(self, size: int = 1024) -> None:
        if size < 1:
            raise ValueError(f"a verdict memo keeps at least one verdict, not {size}")
        self._size = size
        self._verdicts: dict[bytes, tuple[wire.Envelope, str | None]] = {}
        self._packets: dict[bytes, Packet] = {}

    def get(self, data: bytes) -> tuple[wire.Envelope, str | None] | None:
        """The verdict kept for ``data``: its envelope and the authentication failure
        (None: authentic), or None when none is kept."""
        return self._verdicts.get(data)

    def put(self, data: bytes, env: wire.Envelope, reason: str | None) -> None:
        """Keep the verdict on ``data``; once ``size`` are kept, all are forgotten first.

        Forgetting all at once rather than the oldest one by one: the receivers of a
        broadcast check it within a few of its transmission times, so the memo needs no
        long memory, and dropping a dict's first entry again and again makes finding the
        next first entry ever slower (CPython scans the slots left behind).
        """
        verdicts = self._verdicts
        if len(verdicts) >= self._size:
            verdicts.clear()
            self._packets.clear()
        verdicts[data] = (env, reason)

    def packet(self, data: bytes) -> Packet | None:
        """The packet a guard decoded from ``data`` and kept (:meth:`keep`), or None."""
        return self._packets.get(data)

    def keep(self, data: bytes, packet: Packet) -> None:
        """Keep ``packet``, decoded from ``data``, for the other receivers, when its body is
        :func:`shareable` (forgotten with the verdicts)."""
        if shareable(packet.body):
            self._packets[data] = packet


def shareable(body: object) -> bool:
    """Whether the receivers of one broadcast may be handed the same decoded ``body``.

    A roster chunk: its entries are read-only (``Sequence``) tuples of numbers. A release
    whose ``gathered`` is empty: its ``sizes`` and ``entries`` are read-only by type, and
    an entry's ``data`` goes to the plugins of its own platform alone. Gathered data go to
    every receiver's plugins, which may change them, so a release with any is decoded by
    each receiver for itself.
    """
    if isinstance(body, wire.Release):
        return not body.gathered
    return isinstance(body, wire.RosterChunk)


class PacketGuard:
    """Seals outgoing packets and checks incoming ones for swarm ``swarm_key``.

    ``gs_public_key`` verifies the ground station's signatures: a
    :class:`~actorswarm.security.ed25519.PublicKey` (what
    :func:`~actorswarm.security.keys.load_keys` gives; it verifies without the
    ``cryptography`` package, as a platform's daemon does) or the same key as
    ``cryptography`` holds it. A ground station's guard
    (``role="ground"``) also holds ``gs_private_key`` (the one matching ``gs_public_key``)
    and signs its packets; a platform's guard must not hold it. ``window`` is the number of
    sequence numbers remembered per sender; ``max_bytes`` the largest packet accepted (the
    core config's ``max_packet_bytes``). ``memo``: a :class:`VerdictMemo` shared with
    guards of the same keys and ``max_bytes`` (a simulator's), or None. See the module
    documentation for the checks and the threat model; :meth:`insecure` makes a guard that
    checks nothing.
    """

    def __init__(
        self,
        swarm_key: bytes,
        gs_public_key: PublicKey | Ed25519PublicKey,
        *,
        gs_private_key: Ed25519PrivateKey | None = None,
        role: Role = "platform",
        window: int = DEFAULT_WINDOW,
        max_bytes: int = wire.DEFAULT_MAX_BYTES,
        memo: VerdictMemo | None = None,
    ) -> None:
        if len(swarm_key) < _MIN_KEY_BYTES:
            raise ValueError(
                f"swarm key of {len(swarm_key)} bytes is too short; use the 32 bytes of a "
                "swarm.key made by `actorswarm keys init`"
            )
        if role == "ground":
            if gs_private_key is None:
                raise ValueError("a ground station's guard needs the ground station's private key")
            if public_key_fingerprint(gs_private_key.public_key()) != public_key_fingerprint(
                gs_public_key
            ):
                raise ValueError(
                    "the ground station's private key does not match its public key: the "
                    "platforms would refuse every signed command"
                )
        elif role == "platform":
            if gs_private_key is not None:
                raise ValueError(
                    "a platform's guard must not hold the ground station's private key: keep "
                    "it on the ground station only"
                )
        else:
            raise ValueError(f"role must be 'platform' or 'ground', got {role!r}")
        if window < 1:
            raise ValueError(f"replay window must be at least 1, got {window}")
        self._init(role=role, window=window, max_bytes=max_bytes)
        # The key itself is kept only inside the MAC; its fingerprint is for repr.
        self._mac: HmacSha256 | None = HmacSha256(bytes(swarm_key))
        self._key_fingerprint = fingerprint(bytes(swarm_key))
        self._public: PublicKey | None = PublicKey.of(gs_public_key)
        self._private = gs_private_key
        self._memo = memo

    def _init(self, *, role: Role, window: int, max_bytes: int) -> None:
        self.role: Role = role
        self.window = window
        self.max_bytes = max_bytes
        #: Refused packets by reason (see :data:`REASONS`).
        self.rejected: Counter[str] = Counter()
        #: Who the refused packets claimed to come from, per reason (at most
        #: :data:`_MAX_NAMED` senders each): unauthenticated, so only a hint — a ground
        #: station hearing its swarm under another key can say "platforms 1-6 (as they
        #: claim)".
        self.refused_from: dict[str, set[int]] = {}
        #: Packets that passed every check.
        self.accepted = 0
        self._senders: dict[int, _Window] = {}

    @classmethod
    def from_keys(
        cls,
        keys: Keys,
        *,
        role: Role = "platform",
        window: int = DEFAULT_WINDOW,
        max_bytes: int = wire.DEFAULT_MAX_BYTES,
    ) -> PacketGuard:
        """A guard from loaded :class:`~actorswarm.security.keys.Keys`; the private key is
        used only for ``role="ground"`` (load it with ``need_private=True`` there)."""
        return cls(
            keys.swarm_key,
            keys.gs_public,
            gs_private_key=keys.gs_private if role == "ground" else None,
            role=role,
            window=window,
            max_bytes=max_bytes,
        )

    @classmethod
    def insecure(
        cls, *, role: Role = "platform", max_bytes: int = wire.DEFAULT_MAX_BYTES
    ) -> PacketGuard:
        """A guard for ``--insecure`` runs: seals nothing, and accepts every packet that
        decodes (no authentication, no replay protection)."""
        guard = cls.__new__(cls)
        guard._init(role=role, window=0, max_bytes=max_bytes)
        guard._mac = None
        guard._key_fingerprint = ""
        guard._public = None
        guard._private = None
        guard._memo = None
        return guard

    @property
    def secure(self) -> bool:
        return self._mac is not None

    def __repr__(self) -> str:
        if self._mac is None or self._public is None:
            return (
                f"PacketGuard(INSECURE, role={self.role!r}: packets are neither authenticated "
                "nor checked for replay)"
            )
        signs = ", signs as the ground station" if self._private is not None else ""
        return (
            f"PacketGuard(role={self.role!r}, swarm key {self._key_fingerprint}, ground "
            f"station {self._public.fingerprint}, window {self.window}{signs})"
        )

    # --- outgoing ---------------------------------------------------------------------------

    def seal(self, data: bytes) -> bytes:
        """``data`` (a packet as the core encoded it, with an empty tag) with its tag.

        The tag is computed once, over the frame exactly as the core made it, and put into
        the empty slot by slicing (:func:`~actorswarm.core.wire.seal_frame`): no decode, no
        re-encode. Only a ground station's guard (``role="ground"``) signs, and only packets
        of sender 0; a packet of sender 0 sealed by a platform's guard is refused by every
        receiver (``unsigned_operator``). Raises
        ``ValueError`` for bytes that are not such a packet: that is a bug of the caller,
        not something from the network.
        """
        if self._mac is None:
            return data
        covered = wire.unsealed_frame(data)
        auth = self._mac.digest(covered)
        # Only a ground station's guard holds the private key; it signs its own packets, not
        # a platform's it relays (its header is read for that: platforms never pay it).
        if self._private is not None and wire.open_frame(data).sender == GROUND_STATION:
            auth += self._private.sign(covered)
        return wire.seal_frame(covered, auth)

    # --- incoming ---------------------------------------------------------------------------

    def check(self, data: bytes, now: float) -> Packet | None:
        """The packet in ``data`` if it passes every check, else ``None`` (counted).

        The frame (size, CRC-32, header) is checked first, then the tag and the signature
        over the raw bytes, then the replay window; only a packet that passed all of them
        has its body decoded, once. ``now`` is the host's clock, kept as when each sender
        was last accepted (:meth:`last_heard`). Never raises on any bytes.
        """
        memo = self._memo if type(data) is bytes else None  # a memo's keys are bytes
        verdict = None if memo is None else memo.get(data)
        if verdict is not None:
            env, reason = verdict
        else:
            try:
                env = wire.open_frame(data, max_bytes=self.max_bytes)
            except WireError:
                self.rejected["malformed"] += 1
                return None
            if self._mac is None:
                return self._decode(env)
            reason = self._authenticate(env, data)
            if memo is not None:
                memo.put(data, env, reason)
        if reason is not None:
            self.rejected[reason] += 1
            named = self.refused_from.setdefault(reason, set())
            if len(named) < _MAX_NAMED:
                named.add(env.sender)
            return None
        state = self._senders.get(env.sender)
        if state is not None and (
            env.incarnation < state.incarnation
            or (env.incarnation == state.incarnation and not state.fresh(env.seq))
        ):
            self.rejected["replay"] += 1
            return None
        packet = self._decode(env) if memo is None else self._decode_shared(env, data, memo)
        if packet is None:
            return None
        if state is None or env.incarnation > state.incarnation:
            self._senders[env.sender] = _Window(env.incarnation, env.seq, self.window, now)
        else:
            state.mark(env.seq)
            state.heard = now
        return packet

    def _decode_shared(self, env: wire.Envelope, data: bytes, memo: VerdictMemo) -> Packet | None:
        """:meth:`_decode`, or the packet another guard of ``memo`` decoded from ``data``."""
        packet = memo.packet(data)
        if packet is not None:
            self.accepted += 1
            return packet
        packet = self._decode(env)
        if packet is not None:
            memo.keep(data, packet)
        return packet

    def _decode(self, env: wire.Envelope) -> Packet | None:
        try:
            packet = wire.decode_body(env)
        except WireError:
            self.rejected["malformed"] += 1
            return None
        self.accepted += 1
        return packet

    def _authenticate(self, env: wire.Envelope, data: bytes) -> str | None:
        """The reason the packet ``data`` (envelope ``env``) is not authentic, or None."""
        assert self._mac is not None and self._public is not None
        auth = env.auth
        if not auth:
            return "unauthenticated"
        operator = env.sender == GROUND_STATION
        if not operator and len(auth) != TAG_BYTES:
            return "bad_tag"
        covered = wire.covered(data, env)
        expected = self._mac.digest(covered)
        if not equal(auth[:TAG_BYTES], expected):
            return "bad_tag"
        if not operator:
            return None
        if len(auth) == TAG_BYTES:
            return "unsigned_operator"
        if len(auth) != TAG_BYTES + SIGNATURE_BYTES:
            return "bad_signature"
        if not self._public.verify(auth[TAG_BYTES:], covered):
            return "bad_signature"
        return None

    # --- replay state -----------------------------------------------------------------------

    def last_heard(self, sender: int) -> float | None:
        """When a packet of ``sender`` (its newest incarnation) was last accepted."""
        state = self._senders.get(sender)
        return None if state is None else state.heard

    def replay_snapshot(self) -> dict[int, tuple[int, int]]:
        """Per sender, ``(incarnation, highest seq)`` accepted: for a host to keep across its
        own restarts (see the threat model)."""
        return {sender: (s.incarnation, s.top) for sender, s in self._senders.items()}

    def restore_replay(self, snapshot: Mapping[int, tuple[int, int]], now: float) -> None:
        """Take a :meth:`replay_snapshot` back: every seq up to the highest one of each
        sender's incarnation counts as seen. State already newer is kept."""
        for sender, (incarnation, top) in snapshot.items():
            state = self._senders.get(sender)
            if state is not None and (
                state.incarnation > incarnation
                or (state.incarnation == incarnation and state.top >= top)
            ):
                continue
            restored = _Window(incarnation, top, self.window, now)
            restored.seen = restored.mask
            self._senders[sender] = restored


__all__ = [
    "DEFAULT_WINDOW",
    "REASONS",
    "SIGNATURE_BYTES",
    "TAG_BYTES",
    "PacketGuard",
    "Role",
    "VerdictMemo",
    "shareable",
]
