"""The packet guard: sealed packets pass, and every forgery, wrong key, replay, damaged or
random packet is refused and counted under its reason, without ever raising.

Packets are built with the real wire encoder (as the core and the ground station build
them); tests that tamper with a packet behind its frame check re-frame it with a correct
CRC-32, so the guard's own checks are what refuse it.
"""

from __future__ import annotations

import secrets
import zlib
from collections import Counter
from pathlib import Path

import msgspec
import pytest
from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey
from hypothesis import given
from hypothesis import strategies as st

from actorswarm.core import wire
from actorswarm.core.node import Node
from actorswarm.core.wire import (
    GROUND_STATION,
    NORMAL,
    URGENT,
    Ack,
    AppMessage,
    Body,
    Data,
    Heartbeat,
    Packet,
    Release,
    ReleaseEntry,
    RosterChunk,
    Sync,
    decode,
    encode,
)
from actorswarm.engine import commands as cmds
from actorswarm.ground.station import GroundStation
from actorswarm.security import DEFAULT_WINDOW, REASONS, PacketGuard, init_keys, load_keys
from actorswarm.security.guard import VerdictMemo, shareable

SWARM = "alpha"
KEY = bytes(range(32))
GS_PRIVATE = Ed25519PrivateKey.generate()
GS_PUBLIC = GS_PRIVATE.public_key()
HEARTBEAT = Heartbeat(is_master=False, epoch=3, master=1)
COMMAND = Data(
    dst=7,
    channel=URGENT,
    seq=1,
    floor=1,
    epoch=0,
    payload=AppMessage(topic=cmds.TOPIC_COMMAND, body=cmds.encode(cmds.Start(sha256="a" * 64))),
)
BODIES: list[Body] = [
    HEARTBEAT,
    COMMAND,
    Data(dst=2, channel=NORMAL, seq=5, floor=3, epoch=1, payload=Sync(epoch=1)),
    Ack(dst=2, dst_incarnation=9, channel=URGENT, seq=0),
    Release(
        epoch=2,
        key=4,
        generation=1,
        outcome=wire.COMPLETE,
        sizes={0: 2},
        entries=[ReleaseEntry(platform=1, part=0, index=1, data={"x": 1.5})],
        gathered=[(1, "a")],
    ),
]


def platform_guard(*, window: int = DEFAULT_WINDOW) -> PacketGuard:
    return PacketGuard(KEY, GS_PUBLIC, window=window)


def ground_guard() -> PacketGuard:
    return PacketGuard(KEY, GS_PUBLIC, gs_private_key=GS_PRIVATE, role="ground")


def raw(*, sender: int = 7, incarnation: int = 2, seq: int = 1, body: Body = HEARTBEAT) -> bytes:
    """A packet as the core encodes it: auth slot empty."""
    return encode(swarm=SWARM, sender=sender, incarnation=incarnation, seq=seq, body=body)


def sealed(**fields: int) -> bytes:
    """A platform's packet sealed by a platform guard."""
    return platform_guard().seal(raw(**fields))


def operator(*, seq: int = 1, incarnation: int = 5, body: Body = COMMAND) -> bytes:
    """A ground-station packet sealed (and signed) by the ground station's guard."""
    return ground_guard().seal(
        raw(sender=GROUND_STATION, incarnation=incarnation, seq=seq, body=body)
    )


def with_auth(data: bytes, auth: bytes) -> bytes:
    """``data`` re-encoded with another auth slot (everything the tag covers unchanged)."""
    p = decode(data)
    return encode(
        swarm=p.swarm,
        sender=p.sender,
        incarnation=p.incarnation,
        seq=p.seq,
        body=p.body,
        auth=auth,
    )


def reframe(frame: bytes) -> bytes:
    return frame + zlib.crc32(frame).to_bytes(4, "big")


def refused(guard: PacketGuard, data: bytes, reason: str) -> None:
    before = guard.accepted
    assert guard.check(data, 0.0) is None
    assert guard.accepted == before
    assert guard.rejected[reason] >= 1, guard.rejected


# --- round trips ----------------------------------------------------------------------------


@pytest.mark.parametrize("body", BODIES, ids=lambda b: type(b).__name__)
def test_platform_packet_round_trip(body: Body) -> None:
    data = raw(body=body, seq=9)
    out = platform_guard().seal(data)
    packet = platform_guard().check(out, 1.0)
    assert packet is not None
    assert len(packet.auth) == 32
    assert packet == Packet(
        swarm=SWARM, sender=7, incarnation=2, seq=9, body=body, auth=packet.auth
    )
    assert wire.signed_part(out) == data[:-4], "the tag covers exactly the core's packet"


@pytest.mark.parametrize("body", BODIES, ids=lambda b: type(b).__name__)
def test_ground_station_packet_is_tagged_and_signed(body: Body) -> None:
    out = operator(body=body)
    for receiver in (platform_guard(), ground_guard()):
        packet = receiver.check(out, 0.0)
        assert packet is not None and packet.body == body
        assert len(packet.auth) == 32 + 64
        assert receiver.accepted == 1 and not receiver.rejected


def test_ground_guard_only_tags_platform_packets_it_relays() -> None:
    out = ground_guard().seal(raw())
    packet = platform_guard().check(out, 0.0)
    assert packet is not None and len(packet.auth) == 32


def test_real_node_and_ground_station_output_passes() -> None:
    node = Node(3, swarm=SWARM, incarnation=4)
    node.tick(0.5)
    gs = GroundStation(swarm=SWARM, incarnation=11)
    gs.send(cmds.Start(sha256="b" * 64), [3], 0.0)
    platform, ground, receiver = platform_guard(), ground_guard(), platform_guard()
    outgoing = [platform.seal(o.data) for o in node.ready().packets]
    outgoing += [ground.seal(o.data) for o in gs.ready().packets]
    assert len(outgoing) >= 2
    packets = [receiver.check(data, 0.6) for data in outgoing]
    assert all(p is not None for p in packets)
    assert receiver.accepted == len(outgoing) and not receiver.rejected
    assert {p.sender for p in packets if p is not None} == {3, GROUND_STATION}


def test_seal_refuses_what_the_core_never_produces() -> None:
    guard = platform_guard()
    with pytest.raises(ValueError, match="not a packet"):
        guard.seal(b"\x00" * 20)
    with pytest.raises(ValueError, match="auth slot is not empty"):
        guard.seal(guard.seal(raw()))


def test_from_keys_on_disk(tmp_path: Path) -> None:
    directory = tmp_path / "keys"
    init_keys(directory)
    ground = PacketGuard.from_keys(load_keys(directory, need_private=True), role="ground")
    platform = PacketGuard.from_keys(load_keys(directory, need_private=True))
    data = ground.seal(raw(sender=GROUND_STATION))
    assert platform.check(data, 0.0) is not None
    assert platform.check(platform.seal(raw()), 0.0) is not None


# --- construction -----------------------------------------------------------------------------


def test_constructor_refuses_unsafe_setups() -> None:
    with pytest.raises(ValueError, match="too short"):
        PacketGuard(b"short", GS_PUBLIC)
    with pytest.raises(ValueError, match="needs the ground station's private key"):
        PacketGuard(KEY, GS_PUBLIC, role="ground")
    with pytest.raises(ValueError, match="does not match"):
        PacketGuard(KEY, GS_PUBLIC, gs_private_key=Ed25519PrivateKey.generate(), role="ground")
    with pytest.raises(ValueError, match="must not hold"):
        PacketGuard(KEY, GS_PUBLIC, gs_private_key=GS_PRIVATE)
    with pytest.raises(ValueError, match="role must be"):
        PacketGuard(KEY, GS_PUBLIC, role="robot")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="window"):
        PacketGuard(KEY, GS_PUBLIC, window=0)


def test_repr_names_fingerprints_never_the_key() -> None:
    text = repr(ground_guard())
    assert KEY.hex() not in text and KEY.hex()[:16] not in text
    assert "role='ground'" in text and "signs" in text
    assert "signs" not in repr(platform_guard())


# --- insecure -------------------------------------------------------------------------------


def test_insecure_guard_passes_packets_through_and_says_so() -> None:
    guard = PacketGuard.insecure()
    assert not guard.secure and platform_guard().secure
    assert "INSECURE" in repr(guard)
    data = raw()
    assert guard.seal(data) is data
    assert guard.check(data, 0.0) is not None
    assert guard.check(data, 0.0) is not None, "no replay protection"
    assert guard.check(raw(sender=GROUND_STATION), 0.0) is not None
    assert guard.check(b"junk", 0.0) is None
    assert guard.accepted == 3 and guard.rejected == Counter(malformed=1)


# --- forgery, wrong keys, impersonation --------------------------------------------------------


def _other_key_sealed() -> bytes:
    return PacketGuard(secrets.token_bytes(32), GS_PUBLIC).seal(raw())


def _altered_body() -> bytes:
    """A genuine tag on a packet whose body was changed (and re-framed)."""
    auth = decode(sealed()).auth
    return encode(
        swarm=SWARM,
        sender=7,
        incarnation=2,
        seq=1,
        body=Heartbeat(is_master=True, epoch=3, master=7),
        auth=auth,
    )


def _altered_header() -> bytes:
    auth = decode(sealed()).auth
    return encode(swarm=SWARM, sender=7, incarnation=2, seq=2, body=HEARTBEAT, auth=auth)


def _stripped_signature() -> bytes:
    data = operator()
    return with_auth(data, decode(data).auth[:32])


def _foreign_signature() -> bytes:
    """Signed by an Ed25519 key that is not the configured ground station's."""
    other = Ed25519PrivateKey.generate()
    guard = PacketGuard(KEY, other.public_key(), gs_private_key=other, role="ground")
    return guard.seal(raw(sender=GROUND_STATION, incarnation=5))


def _captured_robot() -> bytes:
    """A platform guard (swarm key, no operator key) sealing a packet as sender 0."""
    return platform_guard().seal(raw(sender=GROUND_STATION, incarnation=5))


def _signature_on_another_packet() -> bytes:
    sig = decode(operator(seq=1)).auth[32:]
    genuine = ground_guard().seal(raw(sender=GROUND_STATION, incarnation=5, seq=2))
    return with_auth(genuine, decode(genuine).auth[:32] + sig)


def _wide_slot(data: bytes) -> bytes:
    """The genuine tag, written as msgpack ``bin16`` instead of ``bin8``: the same values,
    other bytes, which the tag does not cover."""
    frame = data[:-4]
    tag = frame[-32:]
    assert frame[-34:-32] == b"\xc4\x20"
    return reframe(frame[:-34] + b"\xc5\x00\x20" + tag)


FORGERIES = [
    ("no tag", raw, "unauthenticated"),
    ("random tag", lambda: with_auth(raw(), secrets.token_bytes(32)), "bad_tag"),
    ("short tag", lambda: with_auth(raw(), decode(sealed()).auth[:31]), "bad_tag"),
    ("tag plus junk", lambda: with_auth(raw(), decode(sealed()).auth + b"\x00" * 64), "bad_tag"),
    ("another swarm key", _other_key_sealed, "bad_tag"),
    ("altered body", _altered_body, "bad_tag"),
    ("altered seq", _altered_header, "bad_tag"),
    ("operator without tag", lambda: raw(sender=GROUND_STATION), "unauthenticated"),
    ("operator, signature stripped", _stripped_signature, "unsigned_operator"),
    ("captured robot as operator", _captured_robot, "unsigned_operator"),
    ("operator, foreign signature", _foreign_signature, "bad_signature"),
    ("operator, signature of another packet", _signature_on_another_packet, "bad_signature"),
    (
        "operator, truncated signature",
        lambda: with_auth(operator(), decode(operator()).auth[:50]),
        "bad_signature",
    ),
    ("tag in a 16-bit length slot", lambda: _wide_slot(sealed()), "bad_tag"),
    ("truncated", lambda: sealed()[:-1], "malformed"),
    ("header only", lambda: sealed()[:10], "malformed"),
    ("empty", lambda: b"", "malformed"),
    ("oversized", lambda: b"\x00" * (wire.DEFAULT_MAX_BYTES + 1), "malformed"),
]


@pytest.mark.parametrize(
    ("make", "reason"), [(f[1], f[2]) for f in FORGERIES], ids=[f[0] for f in FORGERIES]
)
def test_forgeries_are_refused_under_their_reason(make: object, reason: str) -> None:
    guard = platform_guard()
    data = make()  # type: ignore[operator]
    refused(guard, data, reason)
    assert guard.rejected == Counter({reason: 1})
    assert reason in REASONS


@pytest.mark.parametrize(
    ("make", "reason"), [(f[1], f[2]) for f in FORGERIES], ids=[f[0] for f in FORGERIES]
)
def test_guards_sharing_a_verdict_memo_refuse_as_guards_without(make: object, reason: str) -> None:
    """Receivers of one broadcast that share a memo (a simulated swarm's) each count the
    same refusal a guard of their own counts, and the memo never lets bytes through."""
    memo = VerdictMemo()
    data = make()  # type: ignore[operator]
    first, second = (PacketGuard(KEY, GS_PUBLIC, memo=memo) for _ in range(2))
    for guard in (first, second):
        refused(guard, data, reason)
        assert guard.rejected == Counter({reason: 1})


def test_guards_sharing_a_verdict_memo_accept_once_each_and_keep_their_windows() -> None:
    memo = VerdictMemo(size=2)
    packets = [sealed(seq=seq) for seq in (1, 2, 3)]  # three: the memo forgets at the third
    guards = [PacketGuard(KEY, GS_PUBLIC, memo=memo) for _ in range(3)]
    for guard in guards:
        for data in packets:
            packet = guard.check(data, 1.0)
            assert packet is not None and packet == decode(data)
        for data in packets:
            assert guard.check(data, 2.0) is None  # each guard's own replay window
        assert guard.accepted == 3 and guard.rejected == Counter({"replay": 3})
    data = sealed(seq=4)
    one, other = (guard.check(data, 3.0) for guard in guards[:2])
    assert one is not None and one == other and one is not other  # each receiver's own
    with pytest.raises(ValueError, match="at least one"):
        VerdictMemo(size=0)


RELEASE = Release(
    epoch=2,
    key=4,
    generation=1,
    outcome=wire.COMPLETE,
    sizes={0: 2},
    entries=[ReleaseEntry(platform=p, part=0, index=p, data=[p, 0.5]) for p in (1, 2)],
)


@pytest.mark.parametrize(
    ("body", "shared"),
    [
        (RosterChunk(epoch=3, version=9, index=0, count=1, members=[(2, 1), (5, 4)]), True),
        (RELEASE, True),
        (msgspec.structs.replace(RELEASE, gathered=[(1, {"seen": [1]})]), False),
        (HEARTBEAT, False),
        (COMMAND, False),
    ],
)
def test_guards_sharing_a_memo_share_only_bodies_their_receivers_only_read(
    body: Body, shared: bool
) -> None:
    """A roster chunk, or a release without gathered data, is decoded once and handed to
    every receiver as it is; anything else each receiver decodes for itself. Either way each
    accepts it, counts it, and keeps its own replay window."""
    assert shareable(body) is shared
    memo = VerdictMemo()
    guards = [PacketGuard(KEY, GS_PUBLIC, memo=memo) for _ in range(3)]
    data = platform_guard().seal(raw(body=body))
    packets = [guard.check(data, 1.0) for guard in guards]
    assert all(p is not None and p == decode(data) for p in packets)
    assert (packets[0] is packets[1] is packets[2]) is shared
    assert all(guard.accepted == 1 and guard.check(data, 2.0) is None for guard in guards)
    small = VerdictMemo(size=1)  # full at one verdict: it forgets the kept packets with them
    first, second = (PacketGuard(KEY, GS_PUBLIC, memo=small) for _ in range(2))
    one = first.check(data, 1.0)
    small.put(b"other", wire.open_frame(data), None)
    assert second.check(data, 1.0) is not one and second.check(data, 2.0) is None


@pytest.mark.parametrize(
    "make",
    [f[1] for f in FORGERIES if f[2] != "malformed"],
    ids=[f[0] for f in FORGERIES if f[2] != "malformed"],
)
def test_a_forged_packet_never_reaches_the_body_decoder(
    make: object, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The tag is checked over the raw bytes first: refusing a forgery costs no body
    decode (a genuine packet costs exactly one)."""
    calls: list[int] = []
    real = wire.decode_body

    def counting(env: wire.Envelope) -> Packet:
        calls.append(env.seq)
        return real(env)

    guard = platform_guard()
    data = make()  # type: ignore[operator]
    monkeypatch.setattr(wire, "decode_body", counting)
    assert guard.check(data, 0.0) is None
    assert calls == []
    assert guard.check(sealed(seq=9), 0.0) is not None
    assert calls == [9]


def test_a_captured_robot_cannot_command_but_the_ground_station_can() -> None:
    guard = platform_guard()
    assert guard.check(_captured_robot(), 0.0) is None
    assert guard.check(operator(), 0.0) is not None
    assert guard.rejected == Counter(unsigned_operator=1) and guard.accepted == 1


# --- replay -------------------------------------------------------------------------------


def test_same_bytes_twice_is_a_replay() -> None:
    guard = platform_guard()
    data = sealed(seq=4)
    assert guard.check(data, 0.0) is not None
    refused(guard, data, "replay")
    assert guard.accepted == 1 and guard.rejected == Counter(replay=1)


def test_a_replayed_operator_command_is_refused() -> None:
    guard = platform_guard()
    data = operator(seq=3)
    assert guard.check(data, 0.0) is not None
    refused(guard, data, "replay")


def test_reordered_packets_inside_the_window_pass_once() -> None:
    guard = platform_guard()
    for seq in (5, 3, 4, 1, 6, 2):
        assert guard.check(sealed(seq=seq), 0.0) is not None, seq
    for seq in range(1, 7):
        refused(guard, sealed(seq=seq), "replay")
    assert guard.accepted == 6 and guard.rejected == Counter(replay=6)


def test_window_edge() -> None:
    guard = platform_guard(window=8)
    assert guard.check(sealed(seq=10), 0.0) is not None
    assert guard.check(sealed(seq=3), 0.0) is not None, "10 - 3 = 7 < 8: inside the window"
    refused(guard, sealed(seq=2), "replay")
    assert guard.check(sealed(seq=11), 0.0) is not None
    refused(guard, sealed(seq=3), "replay")
    assert guard.check(sealed(seq=4), 0.0) is not None


def test_an_old_seq_after_the_window_moved_is_a_replay() -> None:
    guard = platform_guard()
    assert guard.check(sealed(seq=1), 0.0) is not None
    assert guard.check(sealed(seq=2000), 0.0) is not None
    refused(guard, sealed(seq=2), "replay")  # never seen, but older than the window
    assert guard.check(sealed(seq=2000 - 1023), 0.0) is not None
    refused(guard, sealed(seq=2000 - 1024), "replay")


def test_an_older_incarnation_after_a_newer_one_is_a_replay() -> None:
    guard = platform_guard()
    assert guard.check(sealed(incarnation=2, seq=500), 0.0) is not None
    assert guard.check(sealed(incarnation=3, seq=1), 0.0) is not None, "a reboot resets"
    refused(guard, sealed(incarnation=2, seq=501), "replay")
    refused(guard, sealed(incarnation=2, seq=1), "replay")
    assert guard.check(sealed(incarnation=3, seq=2), 0.0) is not None


def test_a_huge_seq_jump_is_cheap_and_keeps_working() -> None:
    guard = platform_guard()
    big = 2**62
    assert guard.check(sealed(seq=1), 0.0) is not None
    assert guard.check(sealed(seq=big), 0.0) is not None
    assert guard.check(sealed(seq=big - 1), 0.0) is not None
    refused(guard, sealed(seq=big), "replay")
    refused(guard, sealed(seq=1), "replay")


def test_windows_are_per_sender() -> None:
    guard = platform_guard()
    for sender in (1, 2, 3):
        assert guard.check(sealed(sender=sender, seq=1), float(sender)) is not None
    assert guard.check(operator(seq=1), 4.0) is not None
    assert guard.last_heard(2) == 2.0 and guard.last_heard(GROUND_STATION) == 4.0
    assert guard.last_heard(9) is None


@pytest.mark.parametrize(
    "forged",
    [
        lambda: with_auth(raw(incarnation=99, seq=2**62), secrets.token_bytes(32)),
        lambda: PacketGuard(secrets.token_bytes(32), GS_PUBLIC).seal(raw(seq=5000)),
        lambda: with_auth(raw(seq=5000), b""),
    ],
    ids=["forged tag", "other key", "no tag"],
)
def test_forged_packets_do_not_move_the_replay_window(forged: object) -> None:
    guard = platform_guard()
    assert guard.check(sealed(seq=1), 0.0) is not None
    assert guard.check(forged(), 0.0) is None  # type: ignore[operator]
    assert guard.check(sealed(seq=2), 0.0) is not None, "a genuine packet still passes"
    assert guard.replay_snapshot() == {7: (2, 2)}


def test_unsigned_operator_packets_do_not_move_the_operator_window() -> None:
    guard = platform_guard()
    robot = platform_guard()
    assert guard.check(robot.seal(raw(sender=GROUND_STATION, incarnation=99, seq=9)), 0.0) is None
    assert guard.check(operator(incarnation=5, seq=1), 0.0) is not None
    assert guard.replay_snapshot() == {GROUND_STATION: (5, 1)}


def test_replay_state_survives_a_restart_of_the_receiver() -> None:
    before = platform_guard()
    for seq in (1, 2, 3):
        assert before.check(sealed(seq=seq), 0.0) is not None
    snapshot = before.replay_snapshot()
    assert snapshot == {7: (2, 3)}
    after = platform_guard()
    after.restore_replay(snapshot, 10.0)
    refused(after, sealed(seq=2), "replay")
    refused(after, sealed(seq=3), "replay")
    assert after.check(sealed(seq=4), 11.0) is not None
    after.restore_replay({7: (2, 1)}, 12.0)  # older than what it knows: ignored
    assert after.replay_snapshot() == {7: (2, 4)}
    after.restore_replay({7: (3, 1)}, 12.0)  # a newer incarnation is taken
    refused(after, sealed(seq=5), "replay")


# --- hostile bytes: never raises, never accepts ----------------------------------------------


def _all_bit_flips(data: bytes) -> list[bytes]:
    """Every single-bit flip of ``data``: raw (the frame check fails) and re-framed with a
    correct CRC (the guard's own checks must refuse it)."""
    frame = data[:-4]
    out = []
    for i in range(len(data) * 8):
        flipped = bytearray(data)
        flipped[i // 8] ^= 1 << (i % 8)
        out.append(bytes(flipped))
        if i < len(frame) * 8:
            out.append(reframe(bytes(flipped[:-4])))
    return out


@pytest.mark.parametrize("make", [sealed, operator], ids=["platform", "operator"])
def test_every_single_bit_flip_is_refused(make: object) -> None:
    original: bytes = make()  # type: ignore[operator]
    for flipped in _all_bit_flips(original):
        guard = platform_guard()  # fresh: the original was never seen, so no replay excuse
        assert guard.check(flipped, 0.0) is None, flipped.hex()
        assert guard.accepted == 0
    assert platform_guard().check(original, 0.0) is not None


@given(st.binary(max_size=300))
def test_random_bytes_never_raise_never_pass(data: bytes) -> None:
    guard = platform_guard()
    assert guard.check(data, 0.0) is None
    assert guard.accepted == 0 and sum(guard.rejected.values()) == 1
    assert set(guard.rejected) <= set(REASONS)


@given(
    st.sampled_from(["platform", "operator"]),
    st.lists(
        st.tuples(
            st.integers(0, 10_000), st.integers(0, 255), st.sampled_from(["set", "ins", "del"])
        ),
        min_size=1,
        max_size=6,
    ),
    st.booleans(),
)
def test_mutated_packets_never_raise_never_pass(
    kind: str, edits: list[tuple[int, int, str]], fix_crc: bool
) -> None:
    original = sealed() if kind == "platform" else operator()
    frame = bytearray(original[:-4] if fix_crc else original)
    for pos, value, op in edits:
        i = pos % (len(frame) + 1)
        if op == "ins":
            frame.insert(i, value)
        elif op == "del" and i < len(frame):
            del frame[i]
        elif i < len(frame):
            frame[i] = value
    data = reframe(bytes(frame)) if fix_crc else bytes(frame)
    guard = platform_guard()
    result = guard.check(data, 0.0)
    if data == original:
        assert result is not None
        return
    if result is not None:
        # Only the very same packet may pass: msgpack allows longer encodings of a header
        # value, and such a re-encoding carries the same covered bytes (the tag covers values,
        # not their encoding). It is the same packet, so the replay window takes it only once.
        assert wire.signed_part(data) == wire.signed_part(original)
        assert guard.check(original, 0.0) is None, "the original is now a replay"
    assert set(guard.rejected) <= set(REASONS)


@given(st.binary(max_size=200))
def test_random_bytes_after_a_genuine_prefix(tail: bytes) -> None:
    genuine = sealed()
    data = genuine[: len(genuine) // 2] + tail
    assert platform_guard().check(data, 0.0) is None or data == genuine
