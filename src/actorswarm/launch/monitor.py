"""What ``actorswarm launch`` shows of each daemon: from its ``status.json`` (master,
actors) and, on Linux, from ``/proc`` (CPU share and resident memory of its process)."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["ProcSample", "Row", "read_status", "sample"]

#: Clock ticks per second, the unit of /proc/PID/stat's CPU times.
_TICKS = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


@dataclass(frozen=True, slots=True)
class ProcSample:
    """A process's CPU time (seconds, user + system) and resident memory (bytes) at ``t``."""

    t: float
    cpu_s: float
    rss: int


def sample(pid: int, t: float) -> ProcSample | None:
    """The process's figures from /proc, or None when they cannot be read (gone, no /proc)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return None
    # The command name (field 2) may hold spaces and parentheses: split after its last ")".
    fields = stat[stat.rfind(")") + 2 :].split()
    try:
        cpu = (int(fields[11]) + int(fields[12])) / _TICKS  # utime, stime
    except (IndexError, ValueError):
        return None
    rss = 0
    for line in status.splitlines():
        if line.startswith("VmRSS:"):
            rss = int(line.split()[1]) * 1024
            break
    return ProcSample(t, cpu, rss)


def read_status(state_dir: Path) -> dict[str, Any]:
    """The daemon's last ``status.json`` ({} before the first, or while it is rewritten)."""
    try:
        data = json.loads((state_dir / "status.json").read_text())
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


@dataclass(slots=True)
class Row:
    """One daemon as the table shows it."""

    platform: int
    pid: int | None = None
    up: bool = False
    exit_code: int | None = None
    restarts: int = 0
    master: int | None = None
    actors: tuple[str, ...] = ()
    incarnation: int | None = None
    cpu_percent: float | None = None
    rss: int | None = None
    last: ProcSample | None = None

    def update(self, status: dict[str, Any], now: ProcSample | None) -> None:
        """Take the figures of a new status and process sample (CPU over the interval
        since the last sample)."""
        master = status.get("master")
        self.master = master if isinstance(master, int) else None
        actors = status.get("actors")
        self.actors = tuple(str(a) for a in actors) if isinstance(actors, list) else ()
        incarnation = status.get("incarnation")
        self.incarnation = incarnation if isinstance(incarnation, int) else None
        if now is None:
            self.cpu_percent = self.rss = None
            return
        if self.last is not None and now.t > self.last.t:
            self.cpu_percent = 100.0 * (now.cpu_s - self.last.cpu_s) / (now.t - self.last.t)
        self.rss = now.rss
        self.last = now
