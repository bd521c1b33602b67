"""An MCAP file as a recorder's sink.

Messages are JSON (message encoding ``json``, schema encoding ``jsonschema``), grouped in
zstd-compressed chunks of at most :data:`CHUNK_BYTES`. A recording made after the fact (a
simulation's) is written to ``NAME.partial`` and renamed when complete, so a failure leaves
no half file. A recording made as it happens (``gs record``) is written in place and, with
``flush_every``, its open chunk is closed and handed to the operating system every that
many seconds of the given clock: a recorder killed (SIGKILL, a crash) leaves a file whose
every chunk but the open one is readable — at most ``flush_every`` seconds lost — and no
summary, which :func:`actorswarm.recording.reader.read_recording` reads anyway.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import IO

from mcap.writer import CompressionType, Writer

from actorswarm.recording.recorder import TOPICS
from actorswarm.recording.schemas import schema_bytes

__all__ = ["CHUNK_BYTES", "McapSink", "RecordingWriteError", "check_writable"]

#: A chunk is closed when it holds this many bytes (before compression).
CHUNK_BYTES = 1 << 20


class RecordingWriteError(OSError):
    """A recording that cannot be written; the message names the file and what to do."""


def _cannot(path: Path, exc: OSError) -> RecordingWriteError:
    why = exc.strerror or str(exc)
    return RecordingWriteError(
        f"{path}: cannot write the recording ({why}); give a path in a writable directory"
    )


def check_writable(path: Path | str) -> None:
    """Refuse, before a run, a recording path that cannot be written (a missing directory,
    no permission): :class:`RecordingWriteError` naming it. Leaves nothing behind."""
    target = Path(path)
    probe = target.with_name(target.name + ".partial")
    try:
        with probe.open("xb"):
            pass
        probe.unlink()
    except FileExistsError:
        pass  # a stale partial file: it is overwritten when the run ends
    except OSError as exc:
        raise _cannot(target, exc) from None


class McapSink:
    """Writes a recorder's channels to the MCAP file ``path``.

    ``atomic``: write ``path.partial`` and rename it at :meth:`close`. ``flush_every`` and
    ``clock``: close the open chunk whenever ``flush_every`` seconds of ``clock()`` passed
    since the last time (module docstring); None: only when full. A file that cannot be
    opened or written raises :class:`RecordingWriteError` naming it.
    """

    def __init__(
        self,
        path: Path | str,
        *,
        atomic: bool = False,
        flush_every: float | None = None,
        clock: Callable[[], float] | None = None,
        chunk_bytes: int = CHUNK_BYTES,
    ) -> None:
        if flush_every is not None and clock is None:
            raise ValueError("flush_every needs a clock")
        self.path = Path(path)
        self._target = self.path.with_name(self.path.name + ".partial") if atomic else self.path
        self._atomic = atomic
        self._flush_every = flush_every
        self._clock = clock
        self._bytes = 0
        try:
            self._stream: IO[bytes] = self._target.open("wb")
        except OSError as exc:
            raise _cannot(self.path, exc) from None
        self._writer = Writer(
            self._stream, chunk_size=chunk_bytes, compression=CompressionType.ZSTD
        )
        self._channels: dict[str, int] = {}
        self._closed = False
        self._guard(self._start)
        self._last_flush = clock() if clock is not None else 0.0

    def _start(self) -> None:
        self._writer.start(profile="", library="actorswarm")
        schemas: dict[str, int] = {}
        for topic, schema in TOPICS.items():
            if schema not in schemas:
                schemas[schema] = self._writer.register_schema(
                    name=schema, encoding="jsonschema", data=schema_bytes(schema)
                )
            self._channels[topic] = self._writer.register_channel(
                topic=topic, message_encoding="json", schema_id=schemas[schema]
            )

    def _guard(self, action: Callable[[], None]) -> None:
        try:
            action()
        except OSError as exc:
            self._abandon()
            raise _cannot(self.path, exc) from None

    def _abandon(self) -> None:
        self._closed = True
        with contextlib.suppress(OSError):
            self._stream.close()
        if self._atomic:
            self._target.unlink(missing_ok=True)

    @property
    def bytes_written(self) -> int:
        """Message bytes given so far (before compression)."""
        return self._bytes

    def message(self, topic: str, log_time: int, data: bytes) -> None:
        channel = self._channels[topic]
        self._bytes += len(data)

        def add() -> None:
            self._writer.add_message(channel, log_time=log_time, data=data, publish_time=log_time)
            if self._clock is not None and self._flush_every is not None:
                now = self._clock()
                if now - self._last_flush >= self._flush_every:
                    self._last_flush = now
                    self._writer.flush()  # type: ignore[no-untyped-call]

        self._guard(add)

    def flush(self) -> None:
        """Close the open chunk and hand everything to the operating system."""
        self._guard(self._writer.flush)

    def metadata(self, name: str, data: Mapping[str, str]) -> None:
        self._guard(lambda: self._writer.add_metadata(name, dict(data)))
        self.flush()  # the metadata says what the file is: on disk before any message

    def attachment(self, name: str, media_type: str, data: bytes, log_time: int) -> None:
        self._guard(
            lambda: self._writer.add_attachment(
                create_time=log_time, log_time=log_time, name=name, media_type=media_type, data=data
            )
        )

    def close(self) -> None:
        """Write the summary and close the file (renamed into place when ``atomic``);
        idempotent."""
        if self._closed:
            return

        def finish() -> None:
            self._writer.finish()  # type: ignore[no-untyped-call]
            self._stream.close()
            if self._atomic:
                os.replace(self._target, self.path)

        self._guard(finish)
        self._closed = True

    def abandon(self) -> None:
        """Stop without finishing (an atomic file is removed)."""
        if not self._closed:
            self._abandon()
