"""Who may use the web ground station: the token, the Host and the Origin checks.

The page commands a swarm, so it is guarded even on one's own machine:

* **Bound to the loopback** (the default, 127.0.0.1): only this machine can connect. A
  token is optional. The ``Host`` header must name the loopback, or a web page elsewhere
  could reach the server through a DNS name of its own that resolves to 127.0.0.1.
* **Bound to another interface**: a token is required (one is generated when none is
  given) and checked on every HTTP request and WebSocket: ``?token=`` in the URL (the
  page's address, printed at start), then a cookie the server sets from it so the page's
  own files load, or an ``Authorization: Bearer`` header for scripts.
* **Always**: a WebSocket whose ``Origin`` is another site is refused, so a page on the
  web cannot drive the operator's ground station through the operator's browser.
"""

from __future__ import annotations

import hmac
import ipaddress
import secrets
from dataclasses import dataclass
from urllib.parse import urlsplit

__all__ = ["COOKIE", "Access", "is_loopback", "policy"]

COOKIE = "actorswarm_token"
_LOOPBACK_NAMES = {"localhost", "localhost.localdomain"}


def is_loopback(host: str) -> bool:
    """Whether ``host`` (a name or an address, IPv6 with or without brackets) is this
    machine's loopback."""
    name = host.strip().strip("[]").lower()
    if name in _LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(name).is_loopback
    except ValueError:
        return False


def _hostname(host_header: str) -> str:
    """``127.0.0.1:8765`` -> ``127.0.0.1``; ``[::1]:80`` -> ``::1``."""
    return urlsplit(f"//{host_header}").hostname or ""


@dataclass(frozen=True, slots=True)
class Access:
    """The checks for one server. ``token`` None: no token is asked for; ``local_only``:
    the Host header must name the loopback."""

    token: str | None = None
    local_only: bool = True

    def host_ok(self, host_header: str | None) -> bool:
        if not self.local_only:
            return True
        return host_header is not None and is_loopback(_hostname(host_header))

    def token_ok(self, *, query: str | None, cookie: str | None, authorization: str | None) -> bool:
        if self.token is None:
            return True
        bearer = None
        if authorization and authorization.lower().startswith("bearer "):
            bearer = authorization[7:].strip()
        expected = self.token.encode()
        return any(
            given is not None and hmac.compare_digest(given.encode(), expected)
            for given in (query, cookie, bearer)
        )

    @staticmethod
    def origin_ok(origin: str | None, host_header: str | None) -> bool:
        """Same-origin only; no Origin at all (a script, not a browser) is fine."""
        if origin is None:
            return True
        if host_header is None:
            return False
        return urlsplit(origin).netloc.lower() == host_header.lower()


def policy(host: str, token: str | None) -> Access:
    """The access of a server bound to ``host``: see the module docstring. A server on
    another interface gets a fresh random token when ``token`` is None."""
    if is_loopback(host):
        return Access(token=token or None, local_only=True)
    return Access(token=token or secrets.token_urlsafe(18), local_only=False)
