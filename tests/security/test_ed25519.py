"""The verify-only Ed25519 key of a platform: it agrees with ``cryptography`` on every
signature, in both of its backends, reads exactly the key files ``keys init`` writes and
says what is wrong with any other, and keeps the daemon's imports free of ``cryptography``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import zlib
from collections.abc import Iterator
from pathlib import Path

import pytest
from cryptography.exceptions import InvalidSignature
from cryptography.hazmat.primitives import serialization
from cryptography.hazmat.primitives.asymmetric import ec, ed448, rsa, x25519
from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey, Ed25519PublicKey
from hypothesis import given, settings
from hypothesis import strategies as st

from actorswarm.core.wire import GROUND_STATION, Heartbeat, encode
from actorswarm.security import PacketGuard, ed25519, fingerprint, init_keys, load_keys
from actorswarm.security.ed25519 import KeyFormatError, PublicKey
from actorswarm.security.keys import public_key_fingerprint

SRC = Path(__file__).resolve().parents[2] / "src"
# RFC 8032, section 7.1, TEST 2: a one-byte message.
RFC_KEY = bytes.fromhex("3d4017c3e843895a92b70aa74d1b7ebc9c982ccf2ec4968cc0cd55f12af4660c")
RFC_MESSAGE = bytes.fromhex("72")
RFC_SIGNATURE = bytes.fromhex(
    "92a009a9f0d4cab8720e820b5f642540a2b27b5416503f8fb3762223ebdb69da085ac1e43e15996e458f3613d0"
    "f11d8c387b2eaeb4302aeeb00d291612bb0c00"
)


@pytest.fixture(params=["sodium", "cryptography"])
def backend(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> Iterator[str]:
    """Each test once per backend; ``cryptography`` as when PyNaCl cannot be imported."""
    if request.param == "cryptography":
        monkeypatch.setitem(sys.modules, "nacl.bindings", None)
    ed25519._sodium.cache_clear()
    yield request.param
    monkeypatch.undo()
    ed25519._sodium.cache_clear()


def flip(data: bytes, index: int) -> bytes:
    """``data`` with one bit of byte ``index`` (modulo its length) changed."""
    i = index % len(data)
    return data[:i] + bytes([data[i] ^ 1]) + data[i + 1 :]


def reference(key: bytes, signature: bytes, data: bytes) -> bool:
    """What ``cryptography`` says (any length of signature: refused is not verified)."""
    try:
        Ed25519PublicKey.from_public_bytes(key).verify(signature, data)
    except InvalidSignature:
        return False
    return True


def test_the_rfc_8032_vector_verifies_in_each_backend(backend: str) -> None:
    key = PublicKey(RFC_KEY)
    assert key.backend == backend
    assert key.verify(RFC_SIGNATURE, RFC_MESSAGE)
    assert not key.verify(RFC_SIGNATURE, b"")
    assert not key.verify(flip(RFC_SIGNATURE, 40), RFC_MESSAGE)


def test_libsodium_verifies_when_pynacl_is_installed() -> None:
    ed25519._sodium.cache_clear()
    assert PublicKey(RFC_KEY).backend == "sodium"


@settings(max_examples=60, deadline=None)
@given(
    seed=st.binary(min_size=32, max_size=32),
    data=st.binary(max_size=300),
    where=st.integers(min_value=0, max_value=10_000),
)
def test_agrees_with_cryptography_on_valid_and_altered_signatures(
    seed: bytes, data: bytes, where: int
) -> None:
    private = Ed25519PrivateKey.from_private_bytes(seed)
    raw = private.public_key().public_bytes_raw()
    signature = private.sign(data)
    key = PublicKey(raw)
    other = Ed25519PrivateKey.from_private_bytes(flip(seed, where)).public_key()
    cases = [
        (raw, signature, data),  # valid
        (raw, flip(signature, where), data),  # altered signature
        (raw, signature, flip(data, where) if data else b"\0"),  # altered data
        (other.public_bytes_raw(), signature, data),  # another key
    ]
    verdicts = [PublicKey(k).verify(s, d) for k, s, d in cases]
    assert verdicts == [reference(k, s, d) for k, s, d in cases]
    assert verdicts == [True, False, False, False]
    assert key.fingerprint == public_key_fingerprint(private.public_key())


@settings(max_examples=60, deadline=None)
@given(raw=st.binary(min_size=32, max_size=32), signature=st.binary(min_size=64, max_size=64))
def test_never_accepts_what_cryptography_refuses_on_arbitrary_keys_and_signatures(
    raw: bytes, signature: bytes
) -> None:
    """On crafted input libsodium is the stricter (small-order points, non-canonical
    encodings): it may refuse what OpenSSL accepts, never the other way round."""
    ed25519._sodium.cache_clear()
    assert PublicKey(raw).backend == "sodium"
    assert not PublicKey(raw).verify(signature, b"m") or reference(raw, signature, b"m")


# A key of small order (the point (x, 0), of order 4) and a signature whose R is the same
# point and S is 0: [S]B = R + [k]A holds for one message in four, and OpenSSL accepts it
# then. No ground station makes such a key; libsodium refuses it for every message.
SMALL_ORDER_KEY = bytes(32)
SMALL_ORDER_SIGNATURE = bytes(64)


def test_a_small_order_key_never_verifies_with_libsodium() -> None:
    ed25519._sodium.cache_clear()
    key = PublicKey(SMALL_ORDER_KEY)
    assert key.backend == "sodium"
    messages = [bytes([n]) for n in range(16)]
    assert not any(key.verify(SMALL_ORDER_SIGNATURE, m) for m in messages)
    # ... where cryptography (OpenSSL) accepts some: the two differ on exactly such input.
    assert any(reference(SMALL_ORDER_KEY, SMALL_ORDER_SIGNATURE, m) for m in messages)


@pytest.mark.parametrize("length", [0, 1, 32, 63, 65, 96, 128])
def test_a_signature_of_the_wrong_length_does_not_verify(backend: str, length: int) -> None:
    signature = (RFC_SIGNATURE * 2)[:length]
    assert PublicKey(RFC_KEY).verify(signature, RFC_MESSAGE) is False
    assert reference(RFC_KEY, signature, RFC_MESSAGE) is False


def test_bytes_like_arguments_verify_as_bytes(backend: str) -> None:
    key = PublicKey(bytearray(RFC_KEY))
    assert key == PublicKey(RFC_KEY) and hash(key) == hash(PublicKey(RFC_KEY))
    assert key.verify(memoryview(RFC_SIGNATURE), memoryview(RFC_MESSAGE))
    assert key.verify(bytearray(RFC_SIGNATURE), bytearray(RFC_MESSAGE))


@pytest.mark.parametrize("length", [0, 31, 33, 64])
def test_a_raw_key_of_the_wrong_length_is_refused_with_its_length(length: int) -> None:
    with pytest.raises(KeyFormatError, match=f"32 raw bytes, got {length} bytes"):
        PublicKey(bytes(length))


def test_without_pynacl_cryptography_verifies(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "nacl.bindings", None)  # as when it is not installed
    ed25519._sodium.cache_clear()
    key = PublicKey(RFC_KEY)
    assert key.backend == "cryptography"
    assert key.verify(RFC_SIGNATURE, RFC_MESSAGE)
    assert not key.verify(RFC_SIGNATURE, b"")
    monkeypatch.undo()
    ed25519._sodium.cache_clear()


def test_a_libsodium_failing_the_known_answer_is_not_used(monkeypatch: pytest.MonkeyPatch) -> None:
    import nacl.bindings

    # A broken binding: it says every signature is valid.
    monkeypatch.setattr(nacl.bindings, "crypto_sign_open", lambda signed, key: signed[64:])
    ed25519._sodium.cache_clear()
    assert PublicKey(RFC_KEY).backend == "cryptography"
    assert not PublicKey(RFC_KEY).verify(RFC_SIGNATURE, b"")
    monkeypatch.undo()
    ed25519._sodium.cache_clear()


# --- key files ------------------------------------------------------------------------------


def test_the_key_file_of_keys_init_loads_with_its_old_fingerprint(tmp_path: Path) -> None:
    paths = init_keys(tmp_path / "keys")
    pem = paths.gs_public.read_bytes()
    theirs = serialization.load_pem_public_key(pem)
    assert isinstance(theirs, Ed25519PublicKey)
    ours = PublicKey.from_pem(pem)
    assert ours.raw == theirs.public_bytes_raw()
    # What public_key_fingerprint showed before: SHA-256 of the raw bytes, 16 hex digits.
    old = fingerprint(
        theirs.public_bytes(serialization.Encoding.Raw, serialization.PublicFormat.Raw)
    )
    assert ours.fingerprint == old == public_key_fingerprint(theirs) == public_key_fingerprint(ours)
    keys = load_keys(paths.directory)
    assert keys.gs_public == ours and keys.gs_fingerprint == old
    private = load_keys(paths.directory, need_private=True).gs_private
    assert private is not None
    assert ours.verify(private.sign(b"command"), b"command")


def test_pem_with_crlf_and_text_before_the_block_is_read() -> None:
    pem = (
        Ed25519PrivateKey.generate()
        .public_key()
        .public_bytes(serialization.Encoding.PEM, serialization.PublicFormat.SubjectPublicKeyInfo)
    )
    expected = PublicKey.from_pem(pem)
    assert PublicKey.from_pem(pem.replace(b"\n", b"\r\n")) == expected
    assert PublicKey.from_pem(b"ground station, 2026\n" + pem) == expected


def _public_pem(
    key: Ed25519PrivateKey
    | ec.EllipticCurvePrivateKey
    | rsa.RSAPrivateKey
    | ed448.Ed448PrivateKey
    | x25519.X25519PrivateKey,
) -> bytes:
    return key.public_key().public_bytes(
        serialization.Encoding.PEM, serialization.PublicFormat.SubjectPublicKeyInfo
    )


GOOD = _public_pem(Ed25519PrivateKey.generate())
BODY = b"".join(GOOD.splitlines()[1:-1])
BAD_PEM: list[tuple[bytes, str]] = [
    ("é".encode() + GOOD, "not a valid PEM public key (not ASCII text)"),
    (b"no pem here\n", "no '-----BEGIN ...-----' line"),
    (GOOD.replace(b"-----END PUBLIC KEY-----", b""), "no '-----END PUBLIC KEY-----' line"),
    (GOOD.replace(BODY, b"not base64 at all!"), "its body is not base64"),
    (GOOD.replace(BODY, BODY[:-8]), "not a valid PEM public key"),
    (GOOD.replace(BODY, BODY[:-4]), "42 bytes of DER, not an Ed25519 SubjectPublicKeyInfo"),
    (
        Ed25519PrivateKey.generate().private_bytes(
            serialization.Encoding.PEM,
            serialization.PrivateFormat.PKCS8,
            serialization.NoEncryption(),
        ),
        "holds a 'PRIVATE KEY' block, not an Ed25519 public key",
    ),
    (GOOD.replace(b"PUBLIC KEY", b"CERTIFICATE"), "holds a 'CERTIFICATE' block"),
    (_public_pem(ec.generate_private_key(ec.SECP256R1())), "holds an elliptic-curve (EC) public"),
    (_public_pem(rsa.generate_private_key(65537, 1024)), "holds an RSA public key"),
    (_public_pem(ed448.Ed448PrivateKey.generate()), "holds an Ed448 public key"),
    (_public_pem(x25519.X25519PrivateKey.generate()), "holds an X25519 public key"),
]


#: Test IDs by the problem alone: the keys are drawn at import, and pytest-xdist's
#: workers must collect the same IDs.
_IDS = [problem for _, problem in BAD_PEM]


@pytest.mark.parametrize(("pem", "problem"), BAD_PEM, ids=_IDS)
def test_pem_that_is_not_an_ed25519_public_key_says_what_it_is(pem: bytes, problem: str) -> None:
    with pytest.raises(KeyFormatError) as err:
        PublicKey.from_pem(pem)
    assert problem in str(err.value)
    assert isinstance(err.value, ValueError)


@pytest.mark.parametrize(("pem", "problem"), BAD_PEM[2:], ids=_IDS[2:])
def test_a_bad_public_key_file_is_a_key_file_error_naming_it(
    tmp_path: Path, pem: bytes, problem: str
) -> None:
    from actorswarm.security import KeyFileError

    paths = init_keys(tmp_path / "keys")
    paths.gs_public.write_bytes(pem)
    with pytest.raises(KeyFileError) as err:
        load_keys(paths.directory)
    assert err.value.path == paths.gs_public
    assert problem in err.value.problem
    assert str(err.value).startswith(f"{paths.gs_public}: ")


# --- the guard and the daemon ---------------------------------------------------------------


def test_a_platform_guard_checks_operator_signatures_in_each_backend(
    backend: str, tmp_path: Path
) -> None:
    directory = init_keys(tmp_path / "keys").directory
    ground = PacketGuard.from_keys(load_keys(directory, need_private=True), role="ground")
    platform = PacketGuard.from_keys(load_keys(directory))
    assert load_keys(directory).gs_public.backend == backend
    beat = Heartbeat(is_master=False, epoch=1, master=1)
    signed = ground.seal(encode(swarm="s", sender=GROUND_STATION, incarnation=1, seq=1, body=beat))
    assert platform.check(signed, 0.0) is not None
    # The signature ends the frame, before its CRC-32: alter it, and frame it again.
    frame = flip(signed[:-4], -10)
    forged = frame + zlib.crc32(frame).to_bytes(4, "big")
    assert platform.check(forged, 0.0) is None
    assert platform.rejected["bad_signature"] == 1


_DAEMON_PATH = """
import json, sys
import actorswarm.daemon.run, actorswarm.security.guard, actorswarm.security.keys
from actorswarm.security import PacketGuard, load_keys
imported = "cryptography" in sys.modules
guard = PacketGuard.from_keys(load_keys(sys.argv[1]))
packet = guard.check(bytes.fromhex(sys.argv[2]), 0.0)
print(json.dumps({"import": imported, "accepted": packet is not None,
                  "rejected": dict(guard.rejected),
                  "backend": load_keys(sys.argv[1]).gs_public.backend,
                  "after": sorted(m for m in sys.modules if m.startswith("cryptography")),
                  "openssl": sorted(m for m in ("ssl", "_ssl", "_hashlib", "hashlib", "hmac")
                                    if m in sys.modules),
                  "mapped": "libcrypto.so" in open("/proc/self/maps").read()}))
"""


def test_the_daemons_path_imports_neither_cryptography_nor_openssl(tmp_path: Path) -> None:
    """A fresh interpreter imports what a platform's daemon runs, loads its keys and checks
    a signed operator packet: ``cryptography`` is never imported, not even to verify, and
    neither is anything that maps OpenSSL (``ssl``, ``hashlib``, ``hmac``)."""
    directory = init_keys(tmp_path / "keys").directory
    ground = PacketGuard.from_keys(load_keys(directory, need_private=True), role="ground")
    beat = Heartbeat(is_master=False, epoch=1, master=1)
    signed = ground.seal(encode(swarm="s", sender=GROUND_STATION, incarnation=1, seq=1, body=beat))
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    result = subprocess.run(
        [sys.executable, "-c", _DAEMON_PATH, str(directory), signed.hex()],
        capture_output=True,
        text=True,
        env=env,
        timeout=60,
        check=True,
    )
    seen = json.loads(result.stdout)
    assert seen["accepted"], seen
    assert seen["import"] is False, seen
    assert seen["backend"] == "sodium" and seen["after"] == [], seen
    assert seen["openssl"] == [] and seen["mapped"] is False, seen
