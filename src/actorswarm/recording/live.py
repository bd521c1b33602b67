"""A live Foxglove view: a recorder's channels served over Foxglove's WebSocket protocol.

:class:`LiveSink` is a :class:`~actorswarm.recording.recorder.Sink` that hands each message
to a Foxglove WebSocket server (the ``foxglove-sdk`` package, the optional extra
``actorswarm[foxglove]``), so Foxglove connects to ``ws://HOST:PORT`` and shows the same
channels a recording holds, as they happen. Nothing of it is imported unless a live view
is asked for. It binds to loopback (127.0.0.1) unless given another address.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from actorswarm.recording.recorder import TOPICS
from actorswarm.recording.schemas import schema_bytes

__all__ = ["DEFAULT_LIVE_PORT", "LiveSink", "LiveUnavailable"]

#: The live view's port: Foxglove's usual one (8765) is the web ground station's, so the next.
DEFAULT_LIVE_PORT = 8766


class LiveUnavailable(RuntimeError):
    """The live view cannot start (the extra is not installed, the port is taken)."""


class LiveSink:
    """A Foxglove WebSocket server on ``host``:``port`` (0: any free port) serving every
    topic of :data:`~actorswarm.recording.recorder.TOPICS`; :attr:`port` is the port it
    listens on. :class:`LiveUnavailable` says why it cannot start."""

    def __init__(
        self, *, host: str = "127.0.0.1", port: int = DEFAULT_LIVE_PORT, name: str = "actorswarm"
    ) -> None:
        try:
            import foxglove
        except ImportError:
            raise LiveUnavailable(
                "the live Foxglove view needs the foxglove extra: "
                "pip install 'actorswarm[foxglove]'"
            ) from None
        self._context = foxglove.Context()
        try:
            self._server = foxglove.start_server(
                name=name, host=host, port=port, context=self._context
            )
        except Exception as exc:  # the SDK raises its own error types for a bind failure
            raise LiveUnavailable(
                f"cannot serve the live view on {host}:{port} ({exc}); choose another --live-port"
            ) from None
        self.host = host
        self.port: int = self._server.port
        self._channels: dict[str, Any] = {}
        for topic, schema in TOPICS.items():
            self._channels[topic] = foxglove.Channel(
                topic,
                schema=foxglove.Schema(
                    name=schema, encoding="jsonschema", data=schema_bytes(schema)
                ),
                message_encoding="json",
                context=self._context,
            )
        self._closed = False

    @property
    def url(self) -> str:
        """What to open in Foxglove (Open connection → Foxglove WebSocket)."""
        return f"ws://{self.host}:{self.port}"

    def message(self, topic: str, log_time: int, data: bytes) -> None:
        self._channels[topic].log(data, log_time=log_time)

    def metadata(self, name: str, data: Mapping[str, str]) -> None:
        """Not served: a live view has no file to describe."""

    def attachment(self, name: str, media_type: str, data: bytes, log_time: int) -> None:
        """Not served (see :meth:`metadata`)."""

    def close(self) -> None:
        """Stop the server (idempotent)."""
        if not self._closed:
            self._closed = True
            self._server.stop()
