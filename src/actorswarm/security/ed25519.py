"""Verifying the ground station's Ed25519 signatures without the ``cryptography`` package.

A platform only ever *verifies*: it holds the ground station's public key and checks the
signature of every operator packet (:mod:`.guard`). Importing ``cryptography`` for that maps
its Rust extension, ``_cffi_backend`` and a second OpenSSL, about 8 MiB resident, into every
daemon. :class:`PublicKey` verifies through the OpenSSL that the interpreter has already
mapped for :mod:`hashlib`, called with :mod:`ctypes`: about 0.6 MiB instead (measured in a
fresh interpreter: import and one verification; docs/benchmarks/README.md, "Daemon memory
and imports").

Backends
--------
``openssl``
    The ``libcrypto`` that CPython's ``_hashlib`` loaded, found by its path in
    ``/proc/self/maps`` (no search, no subprocess), opened again with :class:`ctypes.CDLL`
    (the same mapping: nothing new is loaded) and called through ``EVP_PKEY_new_raw_public_key``
    and ``EVP_DigestVerify``, which OpenSSL has had since 1.1.1. Before its first use it must
    pass a known-answer test (RFC 8032, section 7.1, test 1: the valid signature verifies, an
    altered one does not).
``cryptography``
    The fallback, imported only when the first is not there: no ``/proc`` (not Linux), an
    interpreter whose OpenSSL is linked statically into ``_hashlib`` or missing, a
    ``libcrypto`` without Ed25519 (older than 1.1.1, or restricted to a FIPS provider without
    it), or one that fails the known-answer test. Both give the same answer for every input.

The choice is made once per process, at the first key built, and :attr:`PublicKey.backend`
says which one it was.

Contract: :meth:`PublicKey.verify` never raises for any signature or data; a signature of
the wrong length, a key that is not a curve point, altered data are all ``False``. Building a
key from anything but 32 raw bytes, or from PEM text that is not an Ed25519
SubjectPublicKeyInfo, is a :class:`KeyFormatError` (a :class:`ValueError`) that says what is
wrong, phrased to follow a file's name (``"ground_station.pub: is not ..."``).
"""

from __future__ import annotations

import base64
import binascii
import ctypes
import functools
import hashlib
from typing import TYPE_CHECKING, Any, Final, Literal, Protocol

if TYPE_CHECKING:
    from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PublicKey

__all__ = ["KEY_BYTES", "SIGNATURE_BYTES", "Backend", "KeyFormatError", "PublicKey"]

#: Bytes of a raw Ed25519 public key.
KEY_BYTES: Final = 32
#: Bytes of an Ed25519 signature.
SIGNATURE_BYTES: Final = 64
#: Which implementation verifies (see the module documentation).
Backend = Literal["openssl", "cryptography"]

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
#: OpenSSL's NID_ED25519 (the same number in 1.1.1 and 3.x).
_EVP_PKEY_ED25519: Final = 1087

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
        return hashlib.sha256(self._raw).hexdigest()[:16]

    @property
    def backend(self) -> Backend:
        """Which implementation verifies (the same for every key of the process)."""
        return "openssl" if isinstance(self._verifier, _OpenSSLKey) else "cryptography"

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
    """``raw`` in the process's backend: OpenSSL through ctypes, else ``cryptography``."""
    openssl = _openssl()
    if openssl is not None:
        verifier = openssl.key(raw)
        if verifier is not None:
            return verifier
    return _CryptographyKey(raw)


@functools.cache
def _openssl() -> _OpenSSL | None:
    """The already-loaded libcrypto, if it is there, has Ed25519 and passes the known-answer
    test; None (use ``cryptography``) otherwise. Decided once per process."""
    path = _libcrypto_path()
    if path is None:
        return None
    try:
        openssl = _OpenSSL(path)
    except (OSError, AttributeError):  # not loadable, or a symbol missing (OpenSSL < 1.1.1)
        return None
    key = openssl.key(_KAT_KEY)
    if key is None:  # no Ed25519 in this libcrypto
        return None
    altered = bytes([_KAT_SIGNATURE[0] ^ 1]) + _KAT_SIGNATURE[1:]
    if (
        not key.verify(_KAT_SIGNATURE, b"")
        or key.verify(altered, b"")
        or key.verify(_KAT_SIGNATURE, b"x")
    ):
        return None
    return openssl


def _libcrypto_path() -> str | None:
    """Where the libcrypto that ``_hashlib`` uses is mapped in this process, or None."""
    try:
        import _hashlib  # noqa: F401  (CPython's OpenSSL binding: it maps libcrypto)
    except ImportError:
        return None
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as maps:
            for line in maps:
                fields = line.split(maxsplit=5)
                if len(fields) < 6:
                    continue
                path = fields[5].rstrip("\n")
                # A library replaced on disk since it was mapped shows as "(deleted)": its
                # path would now open another file.
                if path.rsplit("/", 1)[-1].startswith("libcrypto.so") and path.startswith("/"):
                    return None if path.endswith(" (deleted)") else path
    except OSError:
        return None
    return None


class _OpenSSL:
    """The EVP functions of libcrypto at ``path`` that Ed25519 verification needs, each
    declared with its C prototype (a wrong declaration would pass pointers as ints)."""

    __slots__ = ("_ctx_free", "_ctx_new", "_err_clear", "_key_free", "_new_key", "_verify",
                 "_verify_init")  # fmt: skip

    def __init__(self, path: str) -> None:
        lib = ctypes.CDLL(path)
        p, size = ctypes.c_void_p, ctypes.c_size_t
        # EVP_PKEY *EVP_PKEY_new_raw_public_key(int type, ENGINE *e,
        #                                       const unsigned char *key, size_t keylen)
        self._new_key = _declare(
            lib.EVP_PKEY_new_raw_public_key, p, ctypes.c_int, p, ctypes.c_char_p, size
        )
        # void EVP_PKEY_free(EVP_PKEY *key)
        self._key_free = _declare(lib.EVP_PKEY_free, None, p)
        # EVP_MD_CTX *EVP_MD_CTX_new(void); void EVP_MD_CTX_free(EVP_MD_CTX *ctx)
        self._ctx_new = _declare(lib.EVP_MD_CTX_new, p)
        self._ctx_free = _declare(lib.EVP_MD_CTX_free, None, p)
        # int EVP_DigestVerifyInit(EVP_MD_CTX *ctx, EVP_PKEY_CTX **pctx, const EVP_MD *type,
        #                          ENGINE *e, EVP_PKEY *pkey)
        self._verify_init = _declare(lib.EVP_DigestVerifyInit, ctypes.c_int, p, p, p, p, p)
        # int EVP_DigestVerify(EVP_MD_CTX *ctx, const unsigned char *sig, size_t siglen,
        #                      const unsigned char *tbs, size_t tbslen)
        self._verify = _declare(
            lib.EVP_DigestVerify, ctypes.c_int, p, ctypes.c_char_p, size, ctypes.c_char_p, size
        )
        # void ERR_clear_error(void): a failure leaves errors in the thread's queue, where
        # the next OpenSSL user (hashlib, ssl) would find them
        self._err_clear = _declare(lib.ERR_clear_error, None)

    def key(self, raw: bytes) -> _OpenSSLKey | None:
        """``raw`` as an OpenSSL key; None when this libcrypto cannot make one."""
        pkey: int | None = self._new_key(_EVP_PKEY_ED25519, None, raw, len(raw))
        if not pkey:
            self._err_clear()
            return None
        return _OpenSSLKey(self, pkey)

    def verify(self, pkey: int, signature: bytes, data: bytes) -> bool:
        ctx: int | None = self._ctx_new()
        if not ctx:
            raise MemoryError("OpenSSL could not allocate a digest context")
        try:
            ok: int = self._verify_init(ctx, None, None, None, pkey)
            if ok == 1:
                ok = self._verify(ctx, signature, len(signature), data, len(data))
            if ok != 1:
                self._err_clear()
            return ok == 1
        finally:
            self._ctx_free(ctx)

    def free(self, pkey: int) -> None:
        self._key_free(pkey)


def _declare(
    function: ctypes._NamedFuncPointer, restype: type[ctypes._SimpleCData[Any]] | None, *args: type
) -> ctypes._NamedFuncPointer:
    function.restype = restype
    function.argtypes = args
    return function


class _OpenSSLKey:
    """An ``EVP_PKEY``, freed with this object. OpenSSL keys are reference-counted and only
    read by a verification, so one key may verify in several threads at once."""

    __slots__ = ("_lib", "_pkey")

    def __init__(self, lib: _OpenSSL, pkey: int) -> None:
        self._lib = lib
        self._pkey = pkey

    def verify(self, signature: bytes, data: bytes) -> bool:
        return self._lib.verify(self._pkey, signature, data)

    def __del__(self) -> None:
        self._lib.free(self._pkey)


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
