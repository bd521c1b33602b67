"""Verifying the ground station's Ed25519 signatures without the ``cryptography`` package
and without OpenSSL.

A platform only ever *verifies*: it holds the ground station's public key and checks the
signature of every operator packet (:mod:`.guard`). Importing ``cryptography`` for that maps
its Rust extension, ``_cffi_backend`` and a second OpenSSL, about 8 MiB resident, into every
daemon; the interpreter's own OpenSSL (``libcrypto``, loaded with :mod:`hashlib`) would cost
3.5 MiB, and the daemon loads it for nothing else (:mod:`actorswarm.core.digest`).
:class:`PublicKey` verifies with libsodium instead, as PyNaCl ships it: about 1 MiB with its
import (docs/benchmarks/README.md, "Daemon memory and imports").

Backends
--------
``sodium``
    ``crypto_sign_open`` of the libsodium inside PyNaCl (a dependency). Before its first use
    it must pass a known-answer test (RFC 8032, section 7.1, test 1: the valid signature
    verifies, altered ones do not).
``cryptography``
    The fallback, imported only when PyNaCl is not installed, cannot be loaded or fails the
    known-answer test.

The two agree on every signature a signer makes, valid or altered. On crafted input they
may differ in one direction only: libsodium also refuses keys and signature points of small
order and non-canonical encodings, which OpenSSL accepts when the equation holds; no key a
ground station generates is such a key. The choice is made once per process, at the first
key built, and :attr:`PublicKey.backend` says which one it was.

Contract: :meth:`PublicKey.verify` never raises for any signature or data; a signature of
the wrong length, a key that is not a curve point, altered data are all ``False``. Building a
key from anything but 32 raw bytes, or from PEM text that is not an Ed25519
SubjectPublicKeyInfo, is a :class:`KeyFormatError` (a :class:`ValueError`) that says what is
wrong, phrased to follow a file's name (``"ground_station.pub: is not ..."``).
"""

from __future__ import annotations

import base64
import binascii
import functools
from collections.abc import Callable
from typing import TYPE_CHECKING, Final, Literal, Protocol

from actorswarm.core.digest import sha256_hex

if TYPE_CHECKING:
    from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PublicKey

__all__ = ["KEY_BYTES", "SIGNATURE_BYTES", "Backend", "KeyFormatError", "PublicKey"]

#: Bytes of a raw Ed25519 public key.
KEY_BYTES: Final = 32
#: Bytes of an Ed25519 signature.
SIGNATURE_BYTES: Final = 64
#: Which implementation verifies (see the module documentation).
Backend = Literal["sodium", "cryptography"]

#: DER of an Ed25519 SubjectPublicKeyInfo (RFC 8410) up to the key: SEQUENCE (42 bytes) of
#: the AlgorithmIdentifier SEQUENCE { OID 1.3.101.112 } and a BIT STRING of 33 bytes (no
#: unused bits, then the 32-byte key). DER is canonical, so every such key starts so.
_SPKI_PREFIX: Final = bytes.fromhex("302a300506032b6570032100")
_PEM_LABEL: Final = "PUBLIC KEY"
#: The DER of the OIDs of other public keys, to name what a wrong file holds.
_OTHER_ALGORITHMS: Final = (
    (bytes.fromhex("06092a864886f70d010101"), "an RSA"),
    (bytes.fromhex("06072a8648ce3d0201"), "an elliptic-curve (EC)"),
    (bytes.fromhex("06072a8648ce380401"), "a DSA"),
    (bytes.fromhex("06032b6571"), "an Ed448"),
    (bytes.fromhex("06032b656e"), "an X25519"),
    (bytes.fromhex("06032b656f"), "an X448"),
)
# RFC 8032, section 7.1, TEST 1 (an empty message): the known answer a backend must give.
_KAT_KEY: Final = bytes.fromhex("d75a980182b10ab7d54bfed3c964073a0ee172f3daa62325af021a68f707511a")
_KAT_SIGNATURE: Final = bytes.fromhex(
    "e5564300c360ac729086e2cc806e828a84877f1eb8e5d974d873e065224901555fb8821590a33bacc61e39"
    "701cf9b46bd25bf5f0595bbe24655141438e7a100b"
)


class KeyFormatError(ValueError):
    """Key material that is not an Ed25519 public key; the message says what it is instead."""


class _Verifier(Protocol):
    """One key in one backend."""

    def verify(self, signature: bytes, data: bytes) -> bool: ...


class PublicKey:
    """An Ed25519 public key that verifies signatures: from its 32 raw bytes, or from the
    PEM SubjectPublicKeyInfo of a key file (:meth:`from_pem`). Immutable; equal when the raw
    bytes are."""

    __slots__ = ("_raw", "_verifier")

    def __init__(self, raw: bytes | bytearray | memoryview) -> None:
        raw = bytes(raw)
        if len(raw) != KEY_BYTES:
            raise KeyFormatError(
                f"an Ed25519 public key is {KEY_BYTES} raw bytes, got {len(raw)} bytes"
            )
        self._raw = raw
        self._verifier = _key(raw)

    @classmethod
    def from_pem(cls, data: bytes) -> PublicKey:
        """The key of a PEM ``PUBLIC KEY`` block (what ``ground_station.pub`` holds).

        Text before the block is ignored, as OpenSSL does; only the first block is read.
        Raises :class:`KeyFormatError` naming the problem: not PEM text, another block (a
        private key, a certificate), a body that is not base64, another kind of key.
        """
        return cls(_spki_key(_pem_body(data)))

    @classmethod
    def of(cls, key: PublicKey | Ed25519PublicKey) -> PublicKey:
        """``key`` itself, or the same key as a ``cryptography`` object holds it."""
        if isinstance(key, PublicKey):
            return key
        return cls(key.public_bytes_raw())

    @property
    def raw(self) -> bytes:
        """The 32 raw bytes of the key."""
        return self._raw

    @property
    def fingerprint(self) -> str:
        """The key's fingerprint: the first 16 hex digits of SHA-256 of its raw bytes, as
        :func:`~actorswarm.security.keys.public_key_fingerprint` shows it."""
        return sha256_hex(self._raw)[:16]

    @property
    def backend(self) -> Backend:
        """Which implementation verifies (the same for every key of the process)."""
        return "sodium" if isinstance(self._verifier, _SodiumKey) else "cryptography"

    def verify(
        self, signature: bytes | bytearray | memoryview, data: bytes | bytearray | memoryview
    ) -> bool:
        """Whether ``signature`` is this key's Ed25519 signature of ``data``. Never raises
        for any bytes: a signature of the wrong length is simply not valid."""
        if len(signature) != SIGNATURE_BYTES:
            return False
        return self._verifier.verify(bytes(signature), bytes(data))

    def __eq__(self, other: object) -> bool:
        return isinstance(other, PublicKey) and other._raw == self._raw

    def __hash__(self) -> int:
        return hash(self._raw)

    def __repr__(self) -> str:
        return f"PublicKey(Ed25519 {self.fingerprint}, {self.backend})"


# --- PEM and DER ---------------------------------------------------------------------------


def _pem_body(data: bytes) -> bytes:
    """The DER of the first PEM block of ``data``, which must be a ``PUBLIC KEY`` one."""
    invalid = "is not a valid PEM public key"
    try:
        text = data.decode("ascii")
    except UnicodeDecodeError:
        raise KeyFormatError(f"{invalid} (not ASCII text)") from None
    lines = [line.strip() for line in text.splitlines()]
    begin = next((i for i, line in enumerate(lines) if line.startswith("-----BEGIN ")), None)
    if begin is None or not lines[begin].endswith("-----"):
        raise KeyFormatError(f"{invalid} (no '-----BEGIN ...-----' line)")
    label = lines[begin][len("-----BEGIN ") : -len("-----")]
    if label != _PEM_LABEL:
        raise KeyFormatError(
            f"holds a '{label}' block, not an Ed25519 public key ('{_PEM_LABEL}' block)"
        )
    end_line = f"-----END {label}-----"
    try:
        end = lines.index(end_line, begin + 1)
    except ValueError:
        raise KeyFormatError(f"{invalid} (no '{end_line}' line)") from None
    try:
        return base64.b64decode("".join(lines[begin + 1 : end]), validate=True)
    except (binascii.Error, ValueError):
        raise KeyFormatError(f"{invalid} (its body is not base64)") from None


def _spki_key(der: bytes) -> bytes:
    """The raw key of an Ed25519 SubjectPublicKeyInfo ``der``."""
    if len(der) == len(_SPKI_PREFIX) + KEY_BYTES and der.startswith(_SPKI_PREFIX):
        return der[len(_SPKI_PREFIX) :]
    # Another algorithm's identifier sits near the start of its SubjectPublicKeyInfo.
    for oid, kind in _OTHER_ALGORITHMS:
        if oid in der[:32]:
            raise KeyFormatError(f"holds {kind} public key, not an Ed25519 public key")
    raise KeyFormatError(
        f"is not a valid PEM public key ({len(der)} bytes of DER, not an Ed25519 "
        f"SubjectPublicKeyInfo: 44 bytes starting {_SPKI_PREFIX.hex()})"
    )


# --- backends ------------------------------------------------------------------------------


def _key(raw: bytes) -> _Verifier:
    """``raw`` in the process's backend: libsodium, else ``cryptography``."""
    sodium = _sodium()
    if sodium is not None:
        return _SodiumKey(raw, *sodium)
    return _CryptographyKey(raw)


#: ``crypto_sign_open(signature + message, key)``: the message, or PyNaCl's ``CryptoError``.
_Open = Callable[[bytes, bytes], bytes]


@functools.cache
def _sodium() -> tuple[_Open, type[Exception]] | None:
    """PyNaCl's ``crypto_sign_open`` and the exception it raises for what does not verify,
    if PyNaCl is installed and passes the known-answer test; None (use ``cryptography``)
    otherwise. Decided once per process."""
    try:
        from nacl.bindings import crypto_sign_open
        from nacl.exceptions import CryptoError
    except ImportError:  # not installed, or its library cannot be loaded
        return None
    key = _SodiumKey(_KAT_KEY, crypto_sign_open, CryptoError)
    altered = bytes([_KAT_SIGNATURE[0] ^ 1]) + _KAT_SIGNATURE[1:]
    if (
        not key.verify(_KAT_SIGNATURE, b"")
        or key.verify(altered, b"")
        or key.verify(_KAT_SIGNATURE, b"x")
    ):
        return None
    return crypto_sign_open, CryptoError


class _SodiumKey:
    """A raw key verified by libsodium (which keeps no state per key: nothing to free)."""

    __slots__ = ("_invalid", "_open", "_raw")

    def __init__(self, raw: bytes, sign_open: _Open, invalid: type[Exception]) -> None:
        self._raw = raw
        self._open = sign_open
        self._invalid = invalid

    def verify(self, signature: bytes, data: bytes) -> bool:
        # BadSignatureError for a forged signature or a key that is not a point: both are
        # CryptoErrors, and "not valid" here.
        try:
            self._open(signature + data, self._raw)
        except self._invalid:
            return False
        return True


class _CryptographyKey:
    """The same key through ``cryptography`` (imported on first use only)."""

    __slots__ = ("_invalid", "_key")

    def __init__(self, raw: bytes) -> None:
        from cryptography.exceptions import InvalidSignature
        from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PublicKey

        self._key = Ed25519PublicKey.from_public_bytes(raw)
        self._invalid = InvalidSignature

    def verify(self, signature: bytes, data: bytes) -> bool:
        try:
            self._key.verify(signature, data)
        except self._invalid:
            return False
        return True
