"""A platform's state directory: what survives a crash of its daemon.

Layout (all written atomically: a temporary file, ``fsync``, then a rename):

``incarnation``
    The incarnation of the last start, as decimal text. Each start takes the next one, so
    the swarm tells a restarted daemon from its previous life (its old packets are stale).
``scripts/<sha256>.xml``
    Every task script deployed to this platform, by content hash.
``running``
    The SHA-256 of the script the platform runs (absent: none started yet), and on a second
    line when its task started on the swarm's shared clock (UTC seconds; absent: unknown).
``replay.json``
    The packet guard's replay windows (per sender: incarnation, highest sequence number
    accepted), so packets recorded before a restart are still refused after it.
``backups/``
    The runtime's backups (:class:`~actorswarm.runtime.storage.FileBackupStore`); a
    restarted daemon restores the latest.

The files a running daemon rewrites (``status.json``, ``replay.json``) go through a
:class:`WritePacer`: written when their content changed, never more often than their
period (flash storage wears, and every write costs the robot time).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from actorswarm.core.digest import sha256_hex
from actorswarm.runtime.storage import FileBackupStore

__all__ = ["StateDir", "WritePacer"]


class WritePacer:
    """When to rewrite a file whose content is made again and again: only when it changed,
    and at most once per ``every`` seconds.

    The caller asks :meth:`due` (cheap) before it builds the content, then :meth:`changed`
    with it: ``content`` is what matters, compared with what was last written; ``meters``
    are counters that move all the time (packets sent and accepted): when only they
    moved, the file is rewritten at most once per ``meters_every`` seconds, so the counters
    it shows are never older than that. ``seen`` is the content already on disk (a file
    restored at start that need not be written back)."""

    def __init__(
        self, every: float, meters_every: float | None = None, *, seen: object = None
    ) -> None:
        self.every = every
        self.meters_every = every if meters_every is None else meters_every
        self._checked = float("-inf")
        self._written = float("-inf")
        self._content: object = seen
        self._meters: object = None
        self.writes = 0

    def due(self, now: float) -> bool:
        """Whether a check is due: ``every`` seconds since the last one."""
        return now - self._checked >= self.every

    def changed(
        self, now: float, content: object, meters: object = None, *, closing: bool = False
    ) -> bool:
        """Record a check at ``now``; True when the file must be written with this content
        (the caller writes it), False when what is on disk still says it or the last check
        was less than ``every`` seconds ago. ``closing`` (the daemon stops): the periods do
        not apply, any difference from what was written is written."""
        same = content == self._content
        if closing:
            if same and meters == self._meters:
                return False
        else:
            if not self.due(now):
                return False
            self._checked = now
            if same and (meters == self._meters or now - self._written < self.meters_every):
                return False
        self._content, self._meters, self._written = content, meters, now
        self.writes += 1
        return True


def _write_atomic(path: Path, data: bytes, *, sync: bool = True) -> None:
    partial = path.with_name(path.name + ".partial")
    with partial.open("wb") as out:
        out.write(data)
        out.flush()
        if sync:
            os.fsync(out.fileno())
    partial.replace(path)


class StateDir:
    """The state directory at ``path`` (created, mode 0700, when missing)."""

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self.path.mkdir(parents=True, exist_ok=True, mode=0o700)
        (self.path / "scripts").mkdir(exist_ok=True)
        self.backups = FileBackupStore(self.path / "backups")

    def __repr__(self) -> str:
        return f"StateDir({str(self.path)!r})"

    def next_incarnation(self) -> int:
        """The incarnation of this start: one more than the last one recorded (0 on a
        fresh directory), recorded before it is returned. A corrupt file counts as 0 and
        is overwritten."""
        file = self.path / "incarnation"
        try:
            last = int(file.read_text().strip())
        except (OSError, ValueError):
            last = -1
        current = max(last + 1, 0)
        _write_atomic(file, f"{current}\n".encode())
        return current

    def save_script(self, script: bytes) -> str:
        """Keep a deployed script; returns its SHA-256."""
        sha = sha256_hex(script)
        _write_atomic(self.path / "scripts" / f"{sha}.xml", script)
        return sha

    def script(self, sha: str) -> bytes | None:
        """A kept script by hash (None: not kept, or its content does not match)."""
        try:
            data = (self.path / "scripts" / f"{sha}.xml").read_bytes()
        except OSError:
            return None
        return data if sha256_hex(data) == sha else None

    def set_running(self, sha: str, began: float | None = None) -> None:
        """The script started here, and when its task started (UTC seconds; None: unknown)."""
        text = sha if began is None else f"{sha}\n{began!r}"
        _write_atomic(self.path / "running", f"{text}\n".encode())

    def running(self) -> str | None:
        """The hash of the script last started here (None: none)."""
        return self._running()[0]

    def began(self) -> float | None:
        """When the task of the script last started here began, on the swarm's shared clock
        (None: none started, or not known — a file of an older daemon, or damaged)."""
        return self._running()[1]

    def _running(self) -> tuple[str | None, float | None]:
        try:
            lines = (self.path / "running").read_text().split()
        except OSError:
            return None, None
        if not lines:
            return None, None
        try:
            began = float(lines[1]) if len(lines) > 1 else None
        except ValueError:
            began = None
        if began is not None and not 0.0 <= began < 1e11:
            began = None  # not a time (nan, inf, negative): as if unknown
        return lines[0], began

    def save_replay_windows(self, windows: dict[int, tuple[int, int]]) -> None:
        data = {str(sender): list(window) for sender, window in windows.items()}
        # Rewritten while the daemon runs: no fsync (flash storage wears), a rename is still
        # atomic.
        _write_atomic(self.path / "replay.json", json.dumps(data).encode(), sync=False)

    def replay_windows(self) -> dict[int, tuple[int, int]]:
        """The saved replay windows ({} when none, or when the file is damaged: a damaged
        file costs protection against replays from before the restart, not the start)."""
        try:
            raw = json.loads((self.path / "replay.json").read_bytes())
            return {int(sender): (int(window[0]), int(window[1])) for sender, window in raw.items()}
        except (OSError, ValueError, TypeError, IndexError, KeyError, AttributeError):
            return {}
