"""Local storage for backups: written atomically, read back whole or not at all.

A backup is one opaque blob (the runtime's snapshot). :class:`FileBackupStore` writes it to a
temporary file in the same directory, flushes it to the disk, then renames it over the
numbered target: a crash in the middle of a write leaves at worst a stray temporary file,
never a half-written backup under a backup's name. Every file starts with a header (magic,
length, CRC-32) so a damaged file is recognised and skipped, and :meth:`latest` returns the
newest intact backup. :class:`MemoryBackupStore` is the same contract in memory, for the
simulator (a simulated platform's "disk" survives its crash).
"""

from __future__ import annotations

import contextlib
import os
import struct
import zlib
from pathlib import Path
from typing import Protocol

_MAGIC = b"ASWB"
_HEADER = struct.Struct(">4sQI")  # magic, payload length, CRC-32 of the payload


class BackupStore(Protocol):
    """Where a platform keeps its backups."""

    def write(self, data: bytes) -> int:
        """Store ``data`` atomically as the newest backup; return its generation (1, 2, …)."""
        ...

    def latest(self) -> bytes | None:
        """The newest intact backup, or None."""
        ...


def _frame(data: bytes) -> bytes:
    return _HEADER.pack(_MAGIC, len(data), zlib.crc32(data)) + data


def _unframe(blob: bytes) -> bytes | None:
    if len(blob) < _HEADER.size:
        return None
    magic, length, crc = _HEADER.unpack_from(blob)
    payload = blob[_HEADER.size :]
    if magic != _MAGIC or length != len(payload) or zlib.crc32(payload) != crc:
        return None
    return payload


class MemoryBackupStore:
    """Backups in memory (they outlive a simulated crash; they are the platform's disk)."""

    def __init__(self, keep: int = 5) -> None:
        self._blobs: list[bytes] = []
        self._keep = keep
        self.generation = 0

    def write(self, data: bytes) -> int:
        self.generation += 1
        self._blobs.append(_frame(data))
        del self._blobs[: -self._keep]
        return self.generation

    def latest(self) -> bytes | None:
        for blob in reversed(self._blobs):
            payload = _unframe(blob)
            if payload is not None:
                return payload
        return None

    def damage_latest(self) -> None:
        """Test helper: flip a byte of the newest backup (as a failing disk would)."""
        if self._blobs:
            blob = bytearray(self._blobs[-1])
            blob[-1] ^= 0xFF
            self._blobs[-1] = bytes(blob)


class FileBackupStore:
    """Numbered backup files ``backup-000001.bin``… in ``directory`` (kept: the newest
    ``keep``).

    The generations on disk are listed once, at the first write (and again by each
    :meth:`latest`), then kept in memory: a daemon writes a backup at every switch of its
    actors, and listing the directory through ``pathlib`` twice per write was a tenth of
    a member's Python time during a run of collective switches."""

    def __init__(self, directory: Path, keep: int = 5) -> None:
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self._dir = os.fspath(self.directory)
        self._keep = keep
        self._generations: list[int] | None = None

    def _scan(self) -> list[int]:
        """The generations of the backup files in the directory, oldest first."""
        found = []
        with os.scandir(self._dir) as entries:
            for entry in entries:
                name = entry.name
                if name.startswith("backup-") and name.endswith(".bin"):
                    try:
                        found.append(int(name[7:-4]))
                    except ValueError:  # not one of ours
                        continue
        found.sort()
        self._generations = found
        return found

    def _path(self, generation: int) -> str:
        return os.path.join(self._dir, f"backup-{generation:06d}.bin")

    def write(self, data: bytes) -> int:
        generations = self._generations if self._generations is not None else self._scan()
        generation = generations[-1] + 1 if generations else 1
        target = self._path(generation)
        tmp = os.path.join(self._dir, f".backup-{generation:06d}.tmp")
        with open(tmp, "wb") as fh:
            fh.write(_frame(data))
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, target)  # atomic: the name appears only once the content is whole
        dir_fd = os.open(self._dir, os.O_RDONLY)
        try:
            os.fsync(dir_fd)  # the rename itself reaches the disk
        finally:
            os.close(dir_fd)
        generations.append(generation)
        while len(generations) > self._keep:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self._path(generations.pop(0)))
        return generation

    def latest(self) -> bytes | None:
        for generation in reversed(self._scan()):
            try:
                with open(self._path(generation), "rb") as fh:
                    payload = _unframe(fh.read())
            except OSError:
                continue
            if payload is not None:
                return payload
        return None
