"""Serving a swarm source over HTTP: uvicorn, in the foreground or in a thread.

:func:`serve` is what the commands call: it binds, prints the page's address (with the
access token when there is one), and serves until interrupted. :class:`Server` is the same
in a background thread, for tests and for hosts that have other work: ``with
Server(source) as server:`` then open ``server.url``. Binding to port 0 picks a free port;
the socket is bound before the thread starts, so ``url`` is right at once.
"""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable
from types import TracebackType

import uvicorn

from actorswarm.web.access import Access, is_loopback, policy
from actorswarm.web.app import create_app
from actorswarm.web.source import SwarmSource

__all__ = ["DEFAULT_HOST", "DEFAULT_PORT", "Server", "serve"]

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8765


def _bind(host: str, port: int) -> socket.socket:
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
    except OSError as exc:
        sock.close()
        raise OSError(
            f"cannot listen on {host}:{port}: {exc.strerror or exc}; "
            "choose another --port (0 picks a free one)"
        ) from None
    sock.listen(128)
    sock.set_inheritable(True)
    return sock


class Server:
    """``source`` served on ``host:port`` (see the module docstring); ``access`` by
    default follows :func:`~actorswarm.web.access.policy`."""

    def __init__(
        self,
        source: SwarmSource,
        *,
        host: str = DEFAULT_HOST,
        port: int = 0,
        token: str | None = None,
        access: Access | None = None,
        frame_hz: float = 10.0,
    ) -> None:
        self.access = access or policy(host, token)
        self.host = host
        self._socket = _bind(host, port)
        self.port: int = self._socket.getsockname()[1]
        app = create_app(source, access=self.access, frame_hz=frame_hz)
        config = uvicorn.Config(app, log_level="warning", lifespan="on", ws_ping_interval=None)
        self._server = uvicorn.Server(config)
        self._thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        """The page's address, with the token when one is asked for."""
        shown = self.host
        if shown in ("0.0.0.0", "::"):
            shown = socket.gethostname()
        elif ":" in shown:
            shown = f"[{shown}]"
        query = f"?token={self.access.token}" if self.access.token else ""
        return f"http://{shown}:{self.port}/{query}"

    def run(self) -> None:
        """Serve in this thread until interrupted (Ctrl-C)."""
        self._server.run(sockets=[self._socket])

    def __enter__(self) -> Server:
        self._thread = threading.Thread(target=self.run, name="web-ground-station", daemon=True)
        self._thread.start()
        deadline = time.monotonic() + 30.0
        while not self._server.started:
            if not self._thread.is_alive() or time.monotonic() > deadline:
                raise RuntimeError("the web ground station did not start")
            time.sleep(0.02)
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self._server.should_exit = True
        if self._thread is not None:
            self._thread.join(timeout=30.0)
        self._socket.close()


def serve(
    source: SwarmSource,
    *,
    host: str = DEFAULT_HOST,
    port: int = DEFAULT_PORT,
    token: str | None = None,
    announce: Callable[[str], None] = print,
) -> None:
    """Serve ``source`` until interrupted, after announcing the page's address."""
    server = Server(source, host=host, port=port, token=token)
    where = "this machine only" if is_loopback(host) else "the network: keep the token secret"
    announce(f"web ground station on {server.url}  ({where}; Ctrl-C to stop)")
    server.run()
