"""Probing: what a daemon process and this machine are doing, read from ``/proc``, and the
JSON lines the daemons log.

Every reader raises OSError when the process it reads is gone; none of them changes
anything.
"""

from __future__ import annotations

import json
import math
import os
import platform as platform_module
import subprocess
from collections.abc import Sequence
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from actorswarm.daemon.launch import LocalSwarm


def read_status_kib(pid: int | str, names: Sequence[str]) -> dict[str, int]:
    """The fields ``names`` (in KiB, e.g. ``VmRSS``, ``VmHWM``) that ``/proc/PID/status``
    has for process ``pid`` (or ``"self"``). OSError when the process is gone."""
    fields: dict[str, int] = {}
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        name, _, value = line.partition(":")
        if name in names:
            fields[name] = int(value.split()[0])
    return fields


def read_memory_kib(pid: int) -> tuple[int, int]:
    """(``VmRSS``, ``RssAnon``) of process ``pid`` in KiB, from ``/proc/PID/status``.
    OSError when the process is gone; ValueError when the fields are missing."""
    fields = read_status_kib(pid, ("VmRSS", "RssAnon"))
    if "VmRSS" not in fields:
        raise ValueError(f"/proc/{pid}/status has no VmRSS (a kernel thread or a zombie?)")
    return fields["VmRSS"], fields.get("RssAnon", fields["VmRSS"])


def read_interface_packets(interface: str = "lo", path: Path = Path("/proc/net/dev")) -> int:
    """Packets ``interface`` received so far (``/proc/net/dev`` of this network namespace);
    -1 when it has no such interface."""
    for line in path.read_text().splitlines()[2:]:
        name, _, counters = line.partition(":")
        if name.strip() == interface:
            return int(counters.split()[1])
    return -1


def read_sleeps(pid: int) -> int:
    """How many times the main thread of process ``pid`` went to sleep so far: its
    voluntary context switches (``/proc/PID/task/PID/status``), which for a daemon are its
    loop's waits (and the few blocking calls it makes). OSError when the process is gone;
    ValueError when the kernel does not count them."""
    for line in Path(f"/proc/{pid}/task/{pid}/status").read_text().splitlines():
        name, _, value = line.partition(":")
        if name == "voluntary_ctxt_switches":
            return int(value)
    raise ValueError(f"/proc/{pid}/task/{pid}/status has no voluntary_ctxt_switches")


def read_cpu_seconds(pid: int, thread: int | None = None) -> float:
    """CPU time process ``pid`` used so far (user + system, all its threads; or only its
    thread ``thread``, e.g. ``pid`` for the main one), seconds. OSError when the process
    is gone."""
    where = f"/proc/{pid}" if thread is None else f"/proc/{pid}/task/{thread}"
    text = Path(f"{where}/stat").read_text()
    # The command name (field 2) is in parentheses and may hold spaces: split after it.
    rest = text[text.rindex(")") + 2 :].split()
    utime, stime = int(rest[11]), int(rest[12])  # fields 14 and 15 of proc(5)
    return (utime + stime) / os.sysconf("SC_CLK_TCK")


def read_cpu_ns(pid: int) -> int:
    """CPU time process ``pid`` used so far, nanoseconds: the sum over its threads of the
    scheduler's run time (``/proc/PID/task/*/schedstat``), exact where
    :func:`read_cpu_seconds` counts in clock ticks (10 ms), too coarse to sum over 30
    processes for one switch. Falls back to the ticks where the kernel keeps no schedstat.
    OSError when the process is gone."""
    total = read = 0
    for task in os.listdir(f"/proc/{pid}/task"):
        try:
            total += int(Path(f"/proc/{pid}/task/{task}/schedstat").read_text().split()[0])
        except FileNotFoundError:  # a thread that just ended, or no schedstat at all
            continue
        read += 1
    return total if read else round(read_cpu_seconds(pid) * 1e9)


def sent_packets(status: dict[str, Any]) -> tuple[float, int] | None:
    """(when, packets sent) from a daemon's ``status.json``, None before its first meters."""
    traffic = status.get("traffic")
    if not isinstance(traffic, dict) or "t" not in status:
        return None
    return float(status["t"]), int(traffic.get("sent_packets", 0))


def _first_field(path: str, prefix: str) -> str | None:
    """The rest of the first line of ``path`` that starts with ``prefix``; None when there
    is none or the file cannot be read."""
    try:
        for line in Path(path).read_text().splitlines():
            if line.startswith(prefix):
                return line[len(prefix) :]
    except OSError:
        pass
    return None


def machine_info() -> dict[str, Any]:
    """What the figures depend on: CPU model and count, memory, OS, Python and Zenoh."""
    model = _first_field("/proc/cpuinfo", "model name")
    memory = _first_field("/proc/meminfo", "MemTotal:")
    try:
        zenoh_version = metadata.version("eclipse-zenoh")
    except metadata.PackageNotFoundError:
        zenoh_version = "unknown"
    return {
        "actorswarm": source_version(),
        "cpu_model": "unknown" if model is None else model.split(":", 1)[1].strip(),
        "cpus": os.cpu_count() or 0,
        "memory_gib": math.nan if memory is None else round(int(memory.split()[0]) / 2**20, 1),
        "os": f"{platform_module.system()} {platform_module.release()}",
        "python": platform_module.python_version(),
        "zenoh": zenoh_version,
    }


def source_version(root: Path | None = None) -> str:
    """The package version, and the git commit of the source when it runs from a checkout
    (``+dirty`` when the working tree differs from it): what the daemons measured ran.
    ``root``: another checkout than this module's."""
    from actorswarm import __version__

    root = root or Path(__file__).resolve().parents[4]
    try:
        commit = subprocess.run(
            ["git", "-C", str(root), "describe", "--always", "--dirty=+dirty"],
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return __version__
    return f"{__version__} ({commit})" if commit else __version__


class LogTail:
    """The JSON lines each daemon logged since :meth:`mark` (other lines are skipped)."""

    def __init__(self, swarm: LocalSwarm) -> None:
        self.swarm = swarm
        self._offset: dict[int, int] = {}
        self._partial: dict[int, bytes] = {}
        self._lines: dict[int, list[dict[str, Any]]] = {}

    def mark(self) -> None:
        """Forget what was logged so far: only later lines count."""
        for p in range(1, self.swarm.size + 1):
            path = self.swarm.log(p)
            self._offset[p] = path.stat().st_size if path.exists() else 0
            self._partial[p] = b""
            self._lines[p] = []

    def lines(self, platform: int) -> list[dict[str, Any]]:
        """Every complete JSON line platform ``platform`` logged since the mark."""
        try:
            with self.swarm.log(platform).open("rb") as f:
                f.seek(self._offset.get(platform, 0))
                data = f.read()
        except OSError:
            data = b""
        self._offset[platform] = self._offset.get(platform, 0) + len(data)
        chunk = self._partial.get(platform, b"") + data
        *complete, self._partial[platform] = chunk.split(b"\n")
        got = self._lines.setdefault(platform, [])
        for raw in complete:
            try:
                line = json.loads(raw)
            except ValueError:
                continue  # not one of the daemon's JSON lines (a library's warning)
            if isinstance(line, dict) and "t" in line and "event" in line:
                got.append(line)
        return got
