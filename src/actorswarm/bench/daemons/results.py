"""What ``bench daemons`` measures and how much: its settings, one record per run, and
their JSON form (a measurement not taken is NaN, written as null)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields
from typing import TYPE_CHECKING, Any, TypeVar

from actorswarm.bench.tables import strict_json

if TYPE_CHECKING:
    from _typeshed import DataclassInstance


#: Seconds a switch's measurement of CPU goes on after the last platform switched: its
#: acknowledgements, the backups and status files the transition writes.
SWITCH_TAIL = 0.2


@dataclass(frozen=True, slots=True)
class Settings:
    """How much to measure. Windows and timeouts are seconds."""

    #: CPU window of each resource measurement.
    window: float = 20.0
    failovers: int = 10
    switches: int = 10
    #: Waiting for a booted swarm (every view full, one master); grows with the size, as
    #: every daemon is a Python process importing Zenoh on the same cores.
    boot_timeout: float = 180.0
    #: Waiting for a new master after a kill, and for a switch to reach every platform.
    run_timeout: float = 15.0
    #: Quiet time after the swarm agreed, before measuring: start-up work is not idling.
    settle: float = 2.0
    #: Measure the resources while the script runs too (the second window).
    script_window: bool = True
    seed: int = 1
    #: How broadcasts travel (``--broadcast``): ``mesh`` or ``multicast`` (on ``group``,
    #: through ``interface``).
    broadcast: str = "mesh"
    group: str = "224.0.0.225:7448"
    interface: str = "lo"
    #: Zenoh's session lease of every daemon, seconds (``--lease``; None: the default).
    lease: float | None = None
    #: A source checkout whose ``src`` the daemons run instead of this one's
    #: (``--daemons-from``): code before and after a change, measured by one harness.
    daemons_from: str | None = None


@dataclass(slots=True)
class ResourceRun:
    """One window over every daemon of a swarm. Lists are per daemon, by platform."""

    phase: str  # "idle" (no script) or "script" (actor A running, ground station connected)
    window_s: float
    platforms: list[int]
    peers: list[int]  # members in each daemon's view at the end of the window
    rss_mib: list[float]
    rss_anon_mib: list[float]
    cpu_pct: list[float]  # of one core
    loadavg_1min: float
    #: Packets ``lo`` received per second over the window (every packet on loopback is
    #: received once, a multicast datagram too, however many sockets take it).
    wire_packets_s: float = math.nan
    #: Packets the daemons sent per second (core sends; a broadcast counts once).
    sent_packets_s: float = math.nan
    #: The master the daemons agreed on at the end of the window (None: they did not).
    master: int | None = None
    #: Per daemon: how often a second its main thread went to sleep (voluntary context
    #: switches of the thread that runs the loop; empty in runs saved before it was
    #: measured). Each is a wake of the loop, the cost a daemon pays per timer or burst.
    sleeps_s: list[float] = field(default_factory=list)

    def cpu_of(self, role: str) -> list[float]:
        """CPU % of the ``"master"`` (one value, or none when there was no agreed
        master) or of the ``"members"`` (every other daemon; all of them without a
        master)."""
        return self._of(role, self.cpu_pct)

    def sleeps_of(self, role: str) -> list[float]:
        """:attr:`sleeps_s` of the master or the members, as :meth:`cpu_of`."""
        return self._of(role, self.sleeps_s) if self.sleeps_s else []

    def _of(self, role: str, values: list[float]) -> list[float]:
        pairs = list(zip(self.platforms, values, strict=True))
        if role == "master":
            return [c for p, c in pairs if p == self.master]
        return [c for p, c in pairs if p != self.master]


@dataclass(slots=True)
class FailoverRun:
    killed: int
    new_master: int | None
    to_claim_s: float  # kill -> the new master's own "master" line (nan: none)
    to_all_s: float  # kill -> the last survivor's line naming the new master (nan: not all)
    survivors: int
    followed: int  # survivors that logged the new master in time
    #: The master the whole swarm agreed on after the killed platform restarted (None: it
    #: did not agree): the restarted platform itself when it took the role back.
    master_after_restart: int | None = None
    error: str = ""


@dataclass(slots=True)
class SwitchRun:
    event: str
    src: str
    dst: str
    expected: int
    switched: int  # platforms that logged the transition in time
    first_s: float  # send -> first platform's transition (nan: none)
    last_s: float  # send -> last platform's transition (nan: not every platform)
    spread_s: float  # last - first platform (nan: not every platform)
    causes: dict[str, int] = field(default_factory=dict)
    error: str = ""
    #: CPU every daemon together spent on the switch beyond its idle rate, seconds (nan: not
    #: measured; see :func:`~actorswarm.bench.daemons.stats.switch_cpu`).
    cpu_s: float = math.nan


@dataclass(slots=True)
class SizeResult:
    size: int
    boot_s: float = math.nan
    resources: list[ResourceRun] = field(default_factory=list)
    failover: list[FailoverRun] = field(default_factory=list)
    switch: list[SwitchRun] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    wall_s: float = 0.0


@dataclass(slots=True)
class BenchResult:
    command: str
    settings: dict[str, Any]
    machine: dict[str, Any]
    config: dict[str, float]
    sizes: list[SizeResult]
    started: str  # UTC, ISO 8601
    wall_s: float = 0.0


_Record = TypeVar("_Record", bound="DataclassInstance")


def _record(cls: type[_Record], data: dict[str, Any]) -> _Record:
    """``cls`` from its fields in ``data``: a float written as null comes back as NaN, one
    absent (a run saved before it was measured) takes its default. TypeError for a field
    ``cls`` does not have or a required one missing; ValueError for a float that is not
    a number."""
    floats = {f.name for f in fields(cls) if f.type == "float"}
    restored = {
        name: (math.nan if value is None else float(value)) if name in floats else value
        for name, value in data.items()
    }
    return cls(**restored)


def from_json(data: dict[str, Any]) -> BenchResult:
    """A result back from :func:`to_json` (to render a saved run again); null times come
    back as NaN. KeyError, TypeError or ValueError for data of another shape."""
    sizes = [
        _record(
            SizeResult,
            {
                **row,
                "resources": [_record(ResourceRun, res) for res in row["resources"]],
                "failover": [_record(FailoverRun, f) for f in row["failover"]],
                "switch": [_record(SwitchRun, w) for w in row["switch"]],
            },
        )
        for row in data["sizes"]
    ]
    return _record(BenchResult, {**data, "sizes": sizes})


def to_json(result: BenchResult) -> dict[str, Any]:
    """Everything measured, run by run (NaN, for what was not measured, as null)."""
    data: dict[str, Any] = strict_json(asdict(result))
    return data
