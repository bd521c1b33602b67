"""SHA-256 and HMAC-SHA256 without OpenSSL give exactly what :mod:`hashlib` and
:mod:`hmac` give, for every key and message."""

from __future__ import annotations

import hashlib
import hmac

from hypothesis import given, settings
from hypothesis import strategies as st

from actorswarm.core.digest import HmacSha256, equal, sha256, sha256_hex


@settings(max_examples=300, deadline=None)
@given(key=st.binary(max_size=200), message=st.binary(max_size=2000))
def test_hmac_sha256_is_the_standard_librarys(key: bytes, message: bytes) -> None:
    mac = HmacSha256(key)
    assert mac.digest(message) == hmac.digest(key, message, hashlib.sha256)
    # The key's padded blocks are hashed once: a second message starts from them again.
    assert mac.digest(message + b"x") == hmac.digest(key, message + b"x", hashlib.sha256)


def test_keys_around_the_block_size_are_padded_or_hashed_as_rfc_2104_says() -> None:
    for length in (0, 1, 63, 64, 65, 128):
        key = bytes(range(length))
        assert HmacSha256(key).digest(b"m") == hmac.digest(key, b"m", hashlib.sha256)


@settings(max_examples=100, deadline=None)
@given(data=st.binary(max_size=5000))
def test_sha256_is_the_standard_librarys(data: bytes) -> None:
    assert sha256(data) == hashlib.sha256(data).digest()
    assert sha256_hex(data) == hashlib.sha256(data).hexdigest()
    assert sha256(memoryview(data)) == sha256(bytearray(data)) == sha256(data)


def test_equal_compares_bytes() -> None:
    assert equal(b"abc", b"abc")
    assert not equal(b"abc", b"abd")
    assert not equal(b"abc", b"ab")
