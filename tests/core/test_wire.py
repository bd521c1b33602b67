"""Wire codec: round trips, frame check, every refusal reason, hostile bytes, signed part.

A packet on the air is a msgpack envelope followed by a 4-byte big-endian CRC-32 of it. Tests
that aim at the checks *behind* the frame check (version, swarm, type, body, field ranges)
build an envelope by hand and then :func:`frame` it with a correct CRC; damaged, truncated or
random bytes are refused by the frame check itself (reason ``checksum``).
"""

from __future__ import annotations

import zlib
from typing import Any

import msgspec
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from actorswarm.core.wire import (
    COMPLETE,
    NEED_ALL,
    NORMAL,
    PROTOCOL_VERSION,
    TIMEOUT,
    URGENT,
    Ack,
    AppMessage,
    BarrierRequest,
    BarrierStale,
    Body,
    Data,
    Envelope,
    Heartbeat,
    Packet,
    Payload,
    Release,
    ReleaseAck,
    ReleaseEntry,
    ReleaseRecord,
    Report,
    RoleClaim,
    RoleDeny,
    RoleGrant,
    RoleRelease,
    RoleRevoke,
    Sync,
    WireError,
    decode,
    decode_body,
    encode,
    open_frame,
    seal_frame,
    signed_part,
    unsealed_frame,
)
from actorswarm.core.wire import covered as covered_part

SWARM = "alpha"

PAYLOADS: list[Payload] = [
    BarrierRequest(key=4, generation=0, need={0: 3}),
    BarrierRequest(
        key=2**31 - 1,
        generation=7,
        need={0: 2, 1: NEED_ALL},
        part=1,
        bid=-1.5,
        data={"slot": [1, 2, 3], "name": "x"},
        timeout=60.0,
        age=0.25,
    ),
    BarrierStale(key=4, generation=1, current=3),
    RoleClaim(role="leader", quota=1, bid=2.0),
    RoleRelease(role="leader"),
    RoleGrant(role="leader"),
    RoleDeny(role="leader", holders=[1, 65535]),
    RoleRevoke(role="track"),
    Sync(epoch=12),
    Report(
        epoch=12,
        generations={4: 3, 5: 0},
        pending=[BarrierRequest(key=5, generation=0, need={0: 2}, age=1.0)],
        released=[ReleaseRecord(key=4, generation=2, part=0, index=1, size=2, outcome=COMPLETE)],
        held=[RoleClaim(role="leader", quota=1)],
        claims=[RoleClaim(role="track", quota=2, bid=0.5)],
    ),
    Report(epoch=0, generations={}, pending=[], released=[], held=[], claims=[]),
    AppMessage(topic="gs/start", body=b"\x00\xff" * 10),
]

BODIES: list[Body] = [
    Heartbeat(is_master=True, epoch=3, master=1),
    Heartbeat(is_master=False, epoch=0, master=0),
    *[
        Data(dst=2, channel=NORMAL, seq=5, floor=3, epoch=1, payload=payload)
        for payload in PAYLOADS
    ],
    Data(dst=65535, channel=URGENT, seq=1, floor=1, epoch=0, payload=Sync(epoch=1)),
    Ack(dst=2, dst_incarnation=9, channel=URGENT, seq=0),
    Release(
        epoch=2,
        key=4,
        generation=1,
        outcome=COMPLETE,
        sizes={0: 2, 1: 1},
        entries=[
            ReleaseEntry(platform=1, part=0, index=1, data={"x": 1.5}),
            ReleaseEntry(platform=3, part=1, index=1),
            ReleaseEntry(platform=2, part=0, index=0),
        ],
        gathered=[(1, "a"), (3, [1, 2])],
    ),
    Release(epoch=2, key=4, generation=2, outcome=TIMEOUT, sizes={}, entries=[]),
    ReleaseAck(dst=1, epoch=2, key=4, generation=1),
]


def frame(raw: bytes) -> bytes:
    """``raw`` followed by its CRC-32, big-endian: what ``encode`` puts on the air."""
    return raw + zlib.crc32(raw).to_bytes(4, "big")


def _encode(body: Body, **header: Any) -> bytes:
    fields: dict[str, Any] = {"swarm": SWARM, "sender": 7, "incarnation": 2, "seq": 41}
    fields.update(header)
    return encode(body=body, **fields)


def _envelope(**changes: Any) -> bytes:
    """An (unframed) envelope built field by field: it can hold what ``encode`` never would."""
    fields: dict[str, Any] = {
        "version": PROTOCOL_VERSION,
        "swarm": SWARM,
        "sender": 7,
        "incarnation": 2,
        "seq": 41,
        "type": 1,
        "body": msgspec.Raw(msgspec.msgpack.encode(Heartbeat(is_master=False, epoch=0, master=0))),
        "auth": b"",
    }
    fields.update(changes)
    return msgspec.msgpack.encode(Envelope(**fields))


def _raw(obj: Any) -> msgspec.Raw:
    return msgspec.Raw(msgspec.msgpack.encode(obj))


VALID = _encode(BODIES[4])  # a Data packet carrying a full BarrierRequest


def _flip(data: bytes, bit: int) -> bytes:
    """``data`` with bit number ``bit`` (0 = most significant bit of the first byte) inverted."""
    damaged = bytearray(data)
    damaged[bit // 8] ^= 0x80 >> (bit % 8)
    return bytes(damaged)


@pytest.mark.parametrize("body", BODIES, ids=lambda b: f"{type(b).__name__}")
def test_round_trip_every_body(body: Body) -> None:
    data = _encode(body, auth=b"tag")
    packet = decode(data, swarm=SWARM)
    expected = Packet(swarm=SWARM, sender=7, incarnation=2, seq=41, body=body, auth=b"tag")
    assert packet == expected, f"{type(body).__name__} did not survive the round trip"
    assert packet.type_name == type(body).__name__


@pytest.mark.parametrize("payload", PAYLOADS, ids=lambda p: type(p).__name__)
def test_round_trip_every_payload(payload: Payload) -> None:
    body = Data(dst=1, channel=NORMAL, seq=1, floor=1, epoch=0, payload=payload)
    packet = decode(_encode(body))
    assert isinstance(packet.body, Data)
    assert packet.body.payload == payload
    assert type(packet.body.payload) is type(payload)


def test_decode_without_swarm_accepts_any_swarm() -> None:
    packet = decode(_encode(BODIES[0], swarm="other"))
    assert packet.swarm == "other"


DECODE_ERRORS: list[tuple[str, bytes, str]] = [
    # refused by the length check: no room for an envelope and its CRC
    ("empty", b"", "malformed"),
    ("nil", b"\xc0", "malformed"),
    ("four-bytes", b"\x00" * 4, "malformed"),
    ("only-a-crc", frame(b""), "malformed"),
    # refused by the frame check: the bytes are not what their CRC says
    ("garbage", b"\xff\xfe\x00 not msgpack", "checksum"),
    ("five-zero-bytes", b"\x00" * 5, "checksum"),
    ("trailing-bytes", VALID + b"\x00", "checksum"),
    ("crc-missing", VALID[:-4], "checksum"),
    ("crc-zeroed", VALID[:-4] + b"\x00" * 4, "checksum"),
    (
        "crc-little-endian",
        VALID[:-4] + zlib.crc32(VALID[:-4]).to_bytes(4, "little"),
        "checksum",
    ),
    ("one-bit-flipped", _flip(VALID, 30), "checksum"),
    ("unframed-envelope", _envelope(version=PROTOCOL_VERSION + 1), "checksum"),
    # a correct CRC over bytes that are not an envelope
    ("framed-nil", frame(b"\xc0"), "malformed"),
    ("framed-garbage", frame(b"\xff\xfe\x00 not msgpack"), "malformed"),
    ("framed-wrong-shape", frame(msgspec.msgpack.encode({"version": 1})), "malformed"),
    ("framed-trailing-bytes", frame(VALID[:-4] + b"\x00"), "malformed"),
    ("framed-deep-nesting", frame(b"\x91" * 5000 + b"\xc0"), "malformed"),
    # a correct CRC over an envelope that fails one semantic check
    ("version-next", frame(_envelope(version=PROTOCOL_VERSION + 1)), "version"),
    ("version-0", frame(_envelope(version=0)), "version"),
    ("version-1", frame(_envelope(version=1)), "version"),
    ("wrong-swarm", frame(_envelope(swarm="beta")), "swarm"),
    ("type-0", frame(_envelope(type=0)), "type"),
    ("type-99", frame(_envelope(type=99)), "type"),
    ("sender-70000", frame(_envelope(sender=70000)), "malformed"),
    ("sender-negative", frame(_envelope(sender=-1)), "malformed"),
    ("seq-negative", frame(_envelope(seq=-1)), "malformed"),
    ("incarnation-negative", frame(_envelope(incarnation=-5)), "malformed"),
    ("version-256", frame(_envelope(version=256)), "malformed"),
    ("swarm-too-long", frame(_envelope(swarm="s" * 65)), "malformed"),
    ("auth-too-long", frame(_envelope(auth=b"a" * 129)), "malformed"),
    ("body-of-other-type", frame(_envelope(type=3)), "malformed"),  # a Heartbeat labelled Ack
    ("body-garbage", frame(_envelope(body=msgspec.Raw(b"\x93\x01"))), "malformed"),
    (
        "heartbeat-master-70000",
        frame(_envelope(body=_raw(Heartbeat(is_master=True, epoch=1, master=70000)))),
        "malformed",
    ),
    (
        "data-seq-0",
        frame(
            _envelope(
                type=2,
                body=_raw(Data(dst=1, channel=1, seq=0, floor=1, epoch=0, payload=Sync(epoch=1))),
            )
        ),
        "malformed",
    ),
    (
        "data-channel-255",
        frame(
            _envelope(
                type=2,
                body=_raw(Data(dst=1, channel=255, seq=1, floor=1, epoch=0, payload=Sync(epoch=1))),
            )
        ),
        "malformed",
    ),
    (
        "data-negative-epoch",
        frame(
            _envelope(
                type=2,
                body=_raw(Data(dst=1, channel=1, seq=1, floor=1, epoch=-1, payload=Sync(epoch=1))),
            )
        ),
        "malformed",
    ),
    (
        "role-quota-0",
        frame(
            _envelope(
                type=2,
                body=_raw(
                    Data(
                        dst=1,
                        channel=1,
                        seq=1,
                        floor=1,
                        epoch=0,
                        payload=RoleClaim(role="leader", quota=0),
                    )
                ),
            )
        ),
        "malformed",
    ),
    (
        "request-need-below-all",
        frame(
            _envelope(
                type=2,
                body=_raw(
                    Data(
                        dst=1,
                        channel=1,
                        seq=1,
                        floor=1,
                        epoch=0,
                        payload=BarrierRequest(key=1, generation=0, need={0: -2}),
                    )
                ),
            )
        ),
        "malformed",
    ),
    (
        "ack-negative-seq",
        frame(_envelope(type=3, body=_raw(Ack(dst=1, dst_incarnation=0, channel=1, seq=-1)))),
        "malformed",
    ),
    (
        "release-index-too-big",
        frame(
            _envelope(
                type=4,
                body=_raw(
                    Release(
                        epoch=1,
                        key=1,
                        generation=0,
                        outcome=1,
                        sizes={0: 1},
                        entries=[ReleaseEntry(platform=1, part=0, index=70000)],
                    )
                ),
            )
        ),
        "malformed",
    ),
    (
        "release-ack-extra-field",
        frame(_envelope(type=5, body=_raw([5, 1, 1, 1, 0, "extra"]))),
        "malformed",
    ),
]


@pytest.mark.parametrize(
    ("data", "reason"), [(d, r) for _, d, r in DECODE_ERRORS], ids=[n for n, _, _ in DECODE_ERRORS]
)
def test_decode_errors(data: bytes, reason: str) -> None:
    with pytest.raises(WireError) as info:
        decode(data, swarm=SWARM)
    assert info.value.reason == reason, (
        f"reason {info.value.reason!r} ({info.value}), want {reason}"
    )
    assert str(info.value).startswith(reason), "the message starts with the reason"


def test_envelope_built_for_errors_is_otherwise_valid() -> None:
    """The error table's envelopes fail for the one field changed, not for their shape."""
    packet = decode(frame(_envelope()), swarm=SWARM)
    assert packet.body == Heartbeat(is_master=False, epoch=0, master=0)


@pytest.mark.parametrize("body", BODIES, ids=lambda b: type(b).__name__)
def test_encode_ends_with_big_endian_crc32_of_the_envelope(body: Body) -> None:
    data = _encode(body, auth=b"tag")
    envelope, check = data[:-4], data[-4:]
    assert check == zlib.crc32(envelope).to_bytes(4, "big"), "frame check sequence"
    assert frame(envelope) == data, "the test helper frames exactly like encode"
    assert msgspec.msgpack.decode(envelope, type=Envelope).auth == b"tag", "CRC comes last"


def test_frame_of_built_envelope_equals_encode() -> None:
    """The hand-built envelope of the error table is byte for byte what ``encode`` sends."""
    heartbeat = Heartbeat(is_master=False, epoch=0, master=0)
    assert frame(_envelope()) == _encode(heartbeat)


@pytest.mark.parametrize("length", range(len(VALID)))
def test_truncated_valid_packet_is_refused(length: int) -> None:
    """Too short for an envelope and a CRC: malformed; otherwise the CRC no longer matches."""
    want = "malformed" if length < 5 else "checksum"
    with pytest.raises(WireError) as info:
        decode(VALID[:length], swarm=SWARM)
    assert info.value.reason == want, f"prefix of {length} bytes: {info.value}, want {want}"


@pytest.mark.parametrize("length", range(len(VALID) - 4))
def test_truncated_envelope_with_a_correct_crc_is_malformed(length: int) -> None:
    """A cut envelope that got a correct CRC anyway is still refused, by the envelope decoder."""
    with pytest.raises(WireError) as info:
        decode(frame(VALID[:length]), swarm=SWARM)
    assert info.value.reason == "malformed", f"framed prefix of {length} bytes: {info.value}"


@pytest.mark.parametrize("seed", range(len(BODIES)), ids=lambda i: f"body{i}")
def test_every_single_bit_flip_is_a_checksum_error(seed: int) -> None:
    """CRC-32 detects every single-bit error: each flipped bit, CRC included, is refused."""
    data = _encode(BODIES[seed])
    wrong = {}
    for bit in range(len(data) * 8):
        try:
            decode(_flip(data, bit), swarm=SWARM)
        except WireError as exc:
            if exc.reason != "checksum":
                wrong[bit] = exc.reason
        else:
            wrong[bit] = "accepted"
    assert wrong == {}, f"{len(data)}-byte packet, bits not refused as checksum: {wrong}"


@settings(max_examples=300, deadline=None)
@given(
    seed=st.sampled_from(range(len(BODIES))),
    where=st.integers(0, 10_000),
    pattern=st.integers(1, 2**32 - 1),
)
def test_every_error_burst_within_32_bits_is_a_checksum_error(
    seed: int, where: int, pattern: int
) -> None:
    """CRC-32 also detects every burst of errors no longer than 32 bits (here: 4 bytes)."""
    data = bytearray(_encode(BODIES[seed]))
    start = where % (len(data) - 3)
    for i, byte in enumerate(pattern.to_bytes(4, "big")):
        data[start + i] ^= byte
    with pytest.raises(WireError) as info:
        decode(bytes(data), swarm=SWARM)
    assert info.value.reason == "checksum", f"burst {pattern:#010x} at byte {start}: {info.value}"


@pytest.mark.parametrize(
    ("sender", "reason"), [(8, None), (65535, None), (70000, "malformed"), (-1, "malformed")]
)
def test_altered_and_reframed_packet_meets_the_semantic_checks(
    sender: int, reason: str | None
) -> None:
    """The CRC catches damage, not forgery: a packet altered and re-framed with a correct CRC
    passes the frame check and is judged by the checks behind it like any other."""
    envelope = msgspec.msgpack.decode(VALID[:-4], type=Envelope)
    altered = msgspec.msgpack.encode(msgspec.structs.replace(envelope, sender=sender))
    with pytest.raises(WireError) as stale:
        decode(altered + VALID[-4:], swarm=SWARM)
    assert stale.value.reason == "checksum", "altered under the old CRC: damaged in transit"
    if reason is None:
        packet = decode(frame(altered), swarm=SWARM)
        assert (packet.sender, packet.body) == (sender, BODIES[4]), "re-framed: accepted"
        return
    with pytest.raises(WireError) as info:
        decode(frame(altered), swarm=SWARM)
    assert info.value.reason == reason, f"re-framed sender {sender}: {info.value}, want {reason}"


def test_oversized_is_refused_before_decoding() -> None:
    big = _encode(
        Data(
            dst=1,
            channel=1,
            seq=1,
            floor=1,
            epoch=0,
            payload=AppMessage(topic="t", body=b"x" * 70_000),
        )
    )
    with pytest.raises(WireError) as info:
        decode(big)
    assert info.value.reason == "oversized"
    assert decode(big, max_bytes=len(big)).sender == 7, "at the limit it is accepted"
    with pytest.raises(WireError) as small:
        decode(VALID, max_bytes=len(VALID) - 1)
    assert small.value.reason == "oversized"
    with pytest.raises(WireError) as garbage:
        decode(b"\xff" * 100, max_bytes=10)
    assert garbage.value.reason == "oversized", "the size check comes first"


def test_version_checked_before_swarm_and_type() -> None:
    with pytest.raises(WireError) as info:
        decode(frame(_envelope(version=PROTOCOL_VERSION + 1, swarm="beta", type=99)), swarm=SWARM)
    assert info.value.reason == "version"
    with pytest.raises(WireError) as info2:
        decode(frame(_envelope(swarm="beta", type=99)), swarm=SWARM)
    assert info2.value.reason == "swarm"


def test_frame_check_comes_before_every_semantic_check() -> None:
    """A damaged packet is refused as damaged, whatever its (untrustworthy) header says."""
    hostile = frame(_envelope(version=PROTOCOL_VERSION + 1, swarm="beta", type=99, sender=70000))
    with pytest.raises(WireError) as info:
        decode(_flip(hostile, 8 * len(hostile) - 1), swarm=SWARM)
    assert info.value.reason == "checksum", f"{info.value}"


# --- robustness: decode returns a Packet or raises WireError, nothing else ----------------


def _decode_total(data: bytes) -> None:
    try:
        packet = decode(data, swarm=SWARM)
    except WireError as exc:
        reasons = {"oversized", "checksum", "malformed", "version", "swarm", "type"}
        assert exc.reason in reasons, exc.reason
        return
    assert isinstance(packet, Packet)
    assert 0 <= packet.sender <= 65535
    assert packet.incarnation >= 0
    assert packet.seq >= 0


@settings(max_examples=400, deadline=None)
@given(st.binary(max_size=200))
def test_decode_arbitrary_bytes_is_total(data: bytes) -> None:
    _decode_total(data)


@settings(max_examples=400, deadline=None)
@given(st.binary(max_size=200).map(frame))
def test_decode_arbitrary_framed_bytes_is_total(data: bytes) -> None:
    """Random bytes with a correct CRC reach the envelope decoder, which must hold too."""
    _decode_total(data)


_SEEDS = [_encode(body) for body in BODIES]
_SEED_ENVELOPES = [seed[:-4] for seed in _SEEDS]


@st.composite
def _mutated(draw: st.DrawFn, seeds: list[bytes] = _SEEDS) -> bytes:
    data = bytearray(draw(st.sampled_from(seeds)))
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["flip", "truncate", "insert", "delete", "replace"]))
        pos = draw(st.integers(0, max(len(data) - 1, 0)))
        if kind == "flip" and data:
            data[pos] ^= 1 << draw(st.integers(0, 7))
        elif kind == "truncate":
            del data[pos:]
        elif kind == "insert":
            data[pos:pos] = draw(st.binary(min_size=1, max_size=8))
        elif kind == "delete" and data:
            del data[pos : pos + draw(st.integers(1, 4))]
        elif kind == "replace" and data:
            data[pos] = draw(st.integers(0, 255))
    return bytes(data)


@settings(max_examples=600, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_mutated())
def test_decode_mutated_packets_is_total(data: bytes) -> None:
    _decode_total(data)


@settings(max_examples=600, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_mutated(_SEED_ENVELOPES).map(frame))
def test_decode_mutated_reframed_envelopes_is_total(data: bytes) -> None:
    """Mutations behind a correct CRC exercise the envelope and body decoders."""
    _decode_total(data)


@settings(max_examples=200, deadline=None)
@given(
    st.one_of(
        st.binary(max_size=100),
        st.binary(max_size=100).map(frame),
        _mutated(),
        _mutated(_SEED_ENVELOPES).map(frame),
    )
)
def test_signed_part_is_total(data: bytes) -> None:
    try:
        part = signed_part(data)
    except WireError as exc:
        assert exc.reason in {"checksum", "malformed"}, exc.reason
        return
    assert isinstance(part, bytes)


# --- signed part --------------------------------------------------------------------------


def test_signed_part_excludes_auth_tag() -> None:
    body = BODIES[0]
    untagged = _encode(body)
    tagged = [_encode(body, auth=tag) for tag in (b"", b"k1", b"\x00" * 128)]
    parts = {signed_part(data) for data in tagged}
    assert len(parts) == 1, "the signed part must not depend on the auth tag"
    (part,) = parts
    assert part == untagged[:-4], "the signed part is the envelope with an empty tag, no CRC"
    assert frame(part) == untagged
    assert b"\x00" * 128 not in part


def test_signed_part_is_stable_and_idempotent() -> None:
    data = _encode(BODIES[4], auth=b"sig")
    part = signed_part(data)
    assert signed_part(data) == part
    assert signed_part(frame(part)) == part, "framed again, the signed part is its own"
    assert decode(frame(part)).body == BODIES[4]


@pytest.mark.parametrize(
    "header",
    [{"swarm": "beta"}, {"sender": 8}, {"incarnation": 3}, {"seq": 42}],
    ids=lambda h: next(iter(h)),
)
def test_signed_part_covers_every_header_field(header: dict[str, Any]) -> None:
    base = signed_part(_encode(BODIES[0], auth=b"x"))
    changed = signed_part(_encode(BODIES[0], auth=b"x", **header))
    assert base != changed, f"changing {header} must change the signed bytes"


def test_signed_part_covers_the_body() -> None:
    one = signed_part(_encode(Heartbeat(is_master=False, epoch=1, master=1)))
    two = signed_part(_encode(Heartbeat(is_master=False, epoch=2, master=1)))
    assert one != two


@pytest.mark.parametrize(
    ("data", "reason"),
    [
        (b"\x01\x02", "malformed"),
        (b"\x01\x02\x03\x04\x05", "checksum"),
        (_flip(VALID, 40), "checksum"),
        (frame(b"\x01\x02"), "malformed"),
    ],
    ids=["too-short", "garbage", "damaged", "framed-garbage"],
)
def test_signed_part_of_garbage_is_wire_error(data: bytes, reason: str) -> None:
    with pytest.raises(WireError) as info:
        signed_part(data)
    assert info.value.reason == reason, f"{info.value}, want {reason}"


# --- sealing by slicing -------------------------------------------------------------------


@pytest.mark.parametrize("auth", [b"t" * 32, b"s" * 96, b"x"], ids=["tag", "tag+signature", "one"])
def test_seal_puts_the_tag_in_the_empty_slot_and_covered_takes_it_out(auth: bytes) -> None:
    data = _encode(BODIES[0])
    covered = unsealed_frame(data)
    assert covered == data[:-4], "what a tag covers is the frame as the core made it"
    sealed = seal_frame(covered, auth)
    assert sealed == _encode(BODIES[0], auth=auth), "the same bytes the encoder would write"
    env = open_frame(sealed)
    assert env.auth == auth and covered_part(sealed, env) == covered
    assert decode_body(env).body == BODIES[0]


def test_seal_refuses_bytes_the_core_never_produces() -> None:
    with pytest.raises(ValueError, match="not empty"):
        unsealed_frame(_encode(BODIES[0], auth=b"x"))
    with pytest.raises(ValueError, match="frame check"):
        unsealed_frame(_flip(_encode(BODIES[0]), 3))
    with pytest.raises(ValueError, match="at most 128"):
        seal_frame(unsealed_frame(_encode(BODIES[0])), b"z" * 129)


@given(st.binary(max_size=120).map(frame))
def test_open_frame_and_covered_are_total(data: bytes) -> None:
    try:
        env = open_frame(data)
    except WireError as exc:
        assert exc.reason in {"checksum", "malformed", "version", "type", "oversized"}
        return
    assert isinstance(covered_part(data, env), bytes)
