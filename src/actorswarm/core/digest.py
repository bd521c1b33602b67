"""SHA-256 and HMAC-SHA256 without loading OpenSSL into the process.

A platform's daemon hashes scripts and backups and tags every packet it sends with
HMAC-SHA256 (:mod:`actorswarm.security.guard`). :mod:`hashlib` and :mod:`hmac` would do it,
but importing either loads CPython's ``_hashlib``, which maps OpenSSL's ``libcrypto``: about
3.5 MiB resident in every daemon for two functions (docs/benchmarks/README.md, "Daemon
memory and imports"). CPython also ships its own SHA-256 in C (``_sha2`` since 3.12,
``_sha256`` before: what :mod:`hashlib` falls back to when it has no OpenSSL), and HMAC is
two hashes (RFC 2104), so this module uses that one. An interpreter without it gets
:mod:`hashlib`'s.

Contract: :func:`sha256` and :class:`HmacSha256` give exactly the bytes :mod:`hashlib` and
:func:`hmac.digest` give for every input (a test compares them on arbitrary keys and
messages); :func:`equal` compares in time that does not depend on where two byte strings
differ, as :func:`hmac.compare_digest` does.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Final, Protocol, cast

__all__ = ["HmacSha256", "equal", "sha256", "sha256_hex"]

#: SHA-256's block size, bytes: what HMAC pads its key to (RFC 2104).
_BLOCK: Final = 64


class _Hash(Protocol):
    """A running SHA-256 (what the C module's ``sha256()`` returns)."""

    def update(self, data: bytes | bytearray | memoryview, /) -> None: ...

    def digest(self) -> bytes: ...

    def hexdigest(self) -> str: ...

    def copy(self) -> _Hash: ...


def _builtin() -> tuple[Callable[..., _Hash], Callable[[bytes, bytes], bool]]:
    """CPython's own SHA-256 (:mod:`hashlib`'s on an interpreter without it) and its
    constant-time comparison."""
    for name in ("_sha2", "_sha256"):
        try:
            module = importlib.import_module(name)
        except ImportError:
            continue
        new = cast("Callable[..., _Hash]", module.sha256)
        break
    else:  # pragma: no cover - CPython always has one of the two
        import hashlib

        new = cast("Callable[..., _Hash]", hashlib.sha256)
    # What hmac.compare_digest is when OpenSSL is missing; CPython has had it since 3.3.
    from _operator import _compare_digest

    return new, _compare_digest


_new, _compare = _builtin()


def sha256(data: bytes | bytearray | memoryview) -> bytes:
    """The SHA-256 digest of ``data`` (32 bytes)."""
    return _new(data).digest()


def sha256_hex(data: bytes | bytearray | memoryview) -> str:
    """The SHA-256 digest of ``data`` in hex (64 digits), as ``hashlib``'s ``hexdigest``."""
    return _new(data).hexdigest()


def equal(a: bytes, b: bytes) -> bool:
    """Whether ``a == b``, in a time that depends on their lengths only (for tags)."""
    return _compare(a, b)


class HmacSha256:
    """HMAC-SHA256 under one key (RFC 2104), with the key's two padded blocks hashed once
    here: a tag then costs two hash copies and two short updates. Immutable."""

    __slots__ = ("_inner", "_outer")

    def __init__(self, key: bytes) -> None:
        if len(key) > _BLOCK:
            key = sha256(key)
        key = key.ljust(_BLOCK, b"\0")
        self._inner = _new(bytes(k ^ 0x36 for k in key))
        self._outer = _new(bytes(k ^ 0x5C for k in key))

    def digest(self, message: bytes | bytearray | memoryview) -> bytes:
        """The 32-byte tag of ``message``."""
        inner = self._inner.copy()
        inner.update(message)
        outer = self._outer.copy()
        outer.update(inner.digest())
        return outer.digest()
