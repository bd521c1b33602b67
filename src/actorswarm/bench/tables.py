"""The results of ``actorswarm bench table1|table2|table3|all``: the paper's Tables I–III.

Every measured quantity is a list of samples, one per repetition (a switch time may hold
many samples per repetition); ``NaN`` is a repetition that failed to produce it — kept, so
a report says "9 of 10" rather than hiding the failure. :func:`summarize` turns a list into
median, p95, p99 and range over the finite samples.

Rows are tagged with ``mode``: ``"sim"`` (virtual time over the simulated radio; the radio
model is in :attr:`TablesReport.radio`) or ``"real"`` (``actorswarm daemon`` processes over
Zenoh on this machine, :attr:`TablesReport.machine`).
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import asdict, astuple, dataclass, field, fields
from typing import Any, Protocol, TypeVar

from actorswarm.core.config import CoreConfig, MembershipKind

__all__ = [
    "MODES",
    "Backend",
    "Plan",
    "Progress",
    "Summary",
    "Table1Row",
    "Table2Row",
    "Table2Sample",
    "Table3Row",
    "TableSettings",
    "TablesReport",
    "from_json",
    "measure",
    "merge",
    "percentile",
    "quiet",
    "record_sample",
    "sample_lists",
    "strict_json",
    "summarize",
    "table1_units",
    "to_json",
]

MODES = ("sim", "real")
CASES = ("switch", "branch")
#: What a Table II or III row saved before rows recorded their membership scheme ran with:
#: the core had only the everyone-to-everyone scheme then.
LEGACY_MEMBERSHIP = "broadcast"


def _default_membership() -> str:
    """The collective core's default scheme: what a row that does not choose one (a real
    daemon's) runs."""
    return CoreConfig().membership


def percentile(values: Sequence[float], q: float) -> float:
    """The ``q`` quantile (0–1) of the finite ``values`` by nearest rank; NaN when none."""
    clean = sorted(v for v in values if not math.isnan(v))
    if not clean:
        return math.nan
    return clean[min(len(clean) - 1, max(0, math.ceil(q * len(clean)) - 1))]


@dataclass(frozen=True, slots=True)
class Summary:
    """Median, p95, p99 and range of the finite samples; ``n`` of them, ``failed`` NaNs."""

    median: float
    p95: float
    p99: float
    lo: float
    hi: float
    n: int
    failed: int

    @property
    def spread(self) -> float:
        """``hi - lo``: how far apart the repetitions landed."""
        return self.hi - self.lo


def summarize(values: Sequence[float]) -> Summary:
    clean = [v for v in values if not math.isnan(v)]
    failed = len(values) - len(clean)
    if not clean:
        nan = math.nan
        return Summary(nan, nan, nan, nan, nan, 0, failed)
    return Summary(
        median=statistics.median(clean),
        p95=percentile(clean, 0.95),
        p99=percentile(clean, 0.99),
        lo=min(clean),
        hi=max(clean),
        n=len(clean),
        failed=failed,
    )


@dataclass(slots=True)
class Table1Row:
    """Framework overhead on one platform while two actors alternate at 1 Hz, and the
    single Actor switch time.

    ``real``: one daemon of a swarm of ``peers + 1`` daemons, every platform alternating;
    ``cpu_pct`` (of one core, all its threads) and ``rss_mib`` one sample per repetition
    window; ``switch_ms`` every switch that daemon made (from the call that switches to the
    end of the new actor's first OODA step).
    ``sim``: ``cpu_pct`` is the simulator's CPU time per platform per second of virtual
    time (an upper bound of the protocol + runtime cost: the simulated radio is included,
    Zenoh is not); ``rss_mib`` is empty (one process hosts every platform); ``switch_ms``
    the runtime's switch time, as in the daemon."""

    mode: str
    plugins: int
    peers: int
    cpu_pct: list[float] = field(default_factory=list)
    rss_mib: list[float] = field(default_factory=list)
    switch_ms: list[float] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)


@dataclass(slots=True)
class Table2Row:
    """One collective transition case at one swarm size, plugin count and loss.

    ``case``: ``"switch"`` — every platform switches A → B on one barrier (``sysNum="all"``);
    ``"branch"`` — the event reaches two randomly chosen platforms, which branch together
    (``sysNum="2"``). One sample per repetition:

    * ``transition_ms``: the ground station sends the event → the last platform switched
      (NaN: not every platform that should switch did, within the run's timeout);
    * ``master_pps`` / ``member_pps``: packets sent + received per second during the
      transition at the master / averaged over the non-masters (heartbeats included);
    * ``bytes_per_packet``: the mean size of those packets on the wire;
    * ``master_packets`` / ``member_packets``: the packets behind the two rates (a rate over
      a short window says little without the count: a faster transition has a higher rate
      for the same packets).

    ``membership``: the collective core's membership scheme the row ran with
    (``CoreConfig.membership``: ``"star"`` or ``"broadcast"``); a real row runs the
    daemons' default. Last, so rows built positionally before it existed still are."""

    mode: str
    case: str
    size: int
    plugins: int
    loss: float = 0.0
    transition_ms: list[float] = field(default_factory=list)
    master_pps: list[float] = field(default_factory=list)
    member_pps: list[float] = field(default_factory=list)
    bytes_per_packet: list[float] = field(default_factory=list)
    master_packets: list[float] = field(default_factory=list)
    member_packets: list[float] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    membership: str = field(default_factory=_default_membership)


@dataclass(frozen=True, slots=True)
class Table2Sample:
    """One repetition of a :class:`Table2Row`: a value for each of its sample lists, in
    the same order (NaN for what the repetition did not produce)."""

    transition_ms: float
    master_pps: float
    member_pps: float
    bytes_per_packet: float
    master_packets: float
    member_packets: float


def sample_lists(row: Table2Row) -> list[list[float]]:
    """The sample lists of ``row``, in :class:`Table2Sample`'s field order."""
    return [getattr(row, f.name) for f in fields(Table2Sample)]


def record_sample(row: Table2Row, sample: Table2Sample | None) -> None:
    """Append one repetition to every sample list of ``row`` (NaN everywhere for None: a
    repetition that failed)."""
    values = [math.nan] * len(fields(Table2Sample)) if sample is None else astuple(sample)
    for samples, value in zip(sample_lists(row), values, strict=True):
        samples.append(value)


@dataclass(slots=True)
class Table3Row:
    """The master's daemon killed → a new master acknowledged by every survivor; one
    sample per repetition (NaN: not every survivor followed one new master in time).
    ``membership`` as in :class:`Table2Row`."""

    mode: str
    size: int
    loss: float = 0.0
    election_ms: list[float] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    membership: str = field(default_factory=_default_membership)


@dataclass(slots=True)
class TablesReport:
    """One run of ``actorswarm bench table*``."""

    command: str
    started: str  # UTC, ISO 8601
    machine: dict[str, Any]
    #: The simulated radio and protocol timing the ``sim`` rows ran with.
    radio: dict[str, Any]
    settings: dict[str, Any]
    table1: list[Table1Row] = field(default_factory=list)
    table2: list[Table2Row] = field(default_factory=list)
    table3: list[Table3Row] = field(default_factory=list)
    wall_s: float = 0.0
    #: Empty for a finished run; otherwise why the rows stop where they do ("in progress",
    #: "interrupted..."). A long run rewrites its JSON after every row, so a run that is cut
    #: short keeps what it measured.
    cut_short: str = ""


def strict_json(value: Any) -> Any:
    """``value`` with every NaN replaced by None, for strict JSON."""
    if isinstance(value, float) and math.isnan(value):
        return None
    if isinstance(value, list):
        return [strict_json(v) for v in value]
    if isinstance(value, dict):
        return {k: strict_json(v) for k, v in value.items()}
    return value


def _restore(value: Any) -> Any:
    if value is None:
        return math.nan
    if isinstance(value, list):
        return [_restore(v) for v in value]
    return value


def to_json(report: TablesReport) -> dict[str, Any]:
    """The report as strict JSON (NaN written as null), with each row's summaries."""
    data: dict[str, Any] = strict_json(asdict(report))
    for table in ("table1", "table2", "table3"):
        for row, out in zip(getattr(report, table), data[table], strict=True):
            out["summary"] = {
                f.name: strict_json(asdict(summarize(getattr(row, f.name))))
                for f in fields(row)
                if f.name != "errors" and isinstance(getattr(row, f.name), list)
            }
    return data


def from_json(data: dict[str, Any]) -> TablesReport:
    """A report back from :func:`to_json`; KeyError/TypeError/ValueError when malformed.
    A Table II or III row saved without a ``membership`` comes back as
    :data:`LEGACY_MEMBERSHIP` (what it was measured with), not as today's default."""

    def rows(cls: Any, items: list[dict[str, Any]]) -> list[Any]:
        names = {f.name for f in fields(cls)}
        out = []
        legacy = {"membership": LEGACY_MEMBERSHIP} if "membership" in names else {}
        for item in items:
            kwargs = {
                k: (_restore(v) if k != "errors" else list(v))
                for k, v in {**legacy, **item}.items()
                if k in names
            }
            out.append(cls(**kwargs))
        return out

    return TablesReport(
        command=str(data["command"]),
        started=str(data["started"]),
        machine=dict(data["machine"]),
        radio=dict(data["radio"]),
        settings=dict(data["settings"]),
        table1=rows(Table1Row, data["table1"]),
        table2=rows(Table2Row, data["table2"]),
        table3=rows(Table3Row, data["table3"]),
        wall_s=float(data["wall_s"]),
        cut_short=str(data.get("cut_short", "")),
    )


class Progress(Protocol):
    """What a long run tells its caller: a line of text, and ``advance`` repetitions done
    since the last call (a failed repetition counts as done). The command line draws a
    progress bar over the planned repetitions."""

    def __call__(self, message: str, *, advance: int = 0) -> None: ...


def quiet(message: str, *, advance: int = 0) -> None:
    """A :class:`Progress` that says nothing."""


@dataclass(frozen=True, slots=True)
class TableSettings:
    """How much to measure, wherever the tables run: one part of each :class:`Backend`
    (the simulator's, :class:`~actorswarm.bench.tables_sim.SimBackend`, and real daemons',
    :class:`~actorswarm.bench.tables_real.DaemonBackend`), which add what is theirs."""

    repeat: int = 10
    #: Table I: the platform measured has this many peers (a swarm of ``peers + 1``).
    peers: int = 30
    #: Table I: the window of each repetition, seconds (virtual ones in the simulator).
    window: float = 10.0
    seed: int = 1


def table1_units(plugins: Sequence[int], settings: TableSettings) -> int:
    """The progress units of Table I, on either backend: one per repetition."""
    return len(plugins) * settings.repeat


@dataclass(slots=True)
class Plan:
    """What one run measures. ``sizes`` are the paper's (both modes); ``big_sizes`` and
    ``losses`` are beyond it (simulator only: Table II(a) and III)."""

    tables: tuple[str, ...]
    modes: tuple[str, ...]
    sizes: list[int]
    big_sizes: list[int]
    plugins: list[int]
    losses: list[float]
    repeat: int
    big_repeat: int
    peers: int
    window: float
    seed: int
    #: Table II's cases: ``switch`` (II(a): also the big sizes and the loss rates) and
    #: ``branch`` (II(b), at the paper's sizes).
    cases: tuple[str, ...] = CASES
    #: The simulated rows of Tables II and III are measured once in each of these membership
    #: schemes (``CoreConfig.membership``); Table I and the real rows run the default.
    memberships: tuple[MembershipKind, ...] = ("star",)
    cells2: list[tuple[str, int, int, float]] = field(default_factory=list)
    cells3: list[tuple[int, float]] = field(default_factory=list)

    def __post_init__(self) -> None:
        least = min(self.plugins)
        cells2: list[tuple[str, int, int, float]] = [
            (case, size, plugins, 0.0)
            for case in CASES
            if case in self.cases
            for size in self.sizes
            for plugins in self.plugins
        ]
        everywhere = sorted(set(self.sizes) | set(self.big_sizes))
        for loss in (0.0, *self.losses) if "switch" in self.cases else ():
            for size in everywhere:
                cell = ("switch", size, least, loss)
                if cell not in cells2:
                    cells2.append(cell)
        self.cells2 = cells2
        self.cells3 = [(size, loss) for loss in (0.0, *self.losses) for size in everywhere]

    def settings(self) -> TableSettings:
        """How much every backend measures."""
        return TableSettings(self.repeat, self.peers, self.window, self.seed)


#: A batch of rows of any table.
Rows = Sequence[Table1Row | Table2Row | Table3Row]


class Backend(Protocol):
    """Where the tables run (the simulator, real daemons): what one :func:`measure` needs
    of it."""

    @property
    def mode(self) -> str:
        """The ``mode`` its rows are tagged with."""
        ...

    def units(self, plan: Plan) -> int:
        """The progress units (repetitions) :meth:`rows` will report for ``plan``."""
        ...

    def rows(self, plan: Plan, progress: Progress) -> Iterator[Rows]:
        """The rows of ``plan``, a batch at a time: the report is saved after each."""
        ...


def measure(
    plan: Plan,
    backends: Sequence[Backend],
    report: TablesReport,
    progress: Progress = quiet,
    row_done: Callable[[], None] = lambda: None,
) -> None:
    """Every row of ``plan`` on every backend whose mode it asks for, in the order given,
    added to ``report``; ``row_done`` after each batch."""
    tables: dict[type, list[Any]] = {
        Table1Row: report.table1,
        Table2Row: report.table2,
        Table3Row: report.table3,
    }
    for backend in backends:
        if backend.mode not in plan.modes:
            continue
        for batch in backend.rows(plan, progress):
            for row in batch:
                tables[type(row)].append(row)
            row_done()


_Row = TypeVar("_Row", Table1Row, Table2Row, Table3Row)


def row_key(row: Table1Row | Table2Row | Table3Row) -> tuple[object, ...]:
    """What a row measures (its table, mode, size, plugins, loss...): every field that is
    not a list of samples."""
    return (type(row).__name__, *(v for v in astuple(row) if not isinstance(v, list)))


def _latest(rows: Iterable[_Row]) -> list[_Row]:
    """One row per :func:`row_key`: the last one given, where the first one was."""
    out: dict[tuple[object, ...], _Row] = {}
    for row in rows:
        out[row_key(row)] = row
    return list(out.values())


def merge(reports: Sequence[TablesReport]) -> TablesReport:
    """One report of several runs (say, the real daemons' and the simulator's at 1000
    platforms, run apart): the rows of each — a row measured again in a later report
    replaces the earlier one (:func:`row_key`) — their commands joined with ``;``, the
    machine and radio of the first, the wall times added, the earliest start. A report
    that is itself a merge keeps its runs' settings flat."""
    if not reports:
        raise ValueError("nothing to merge")
    first = reports[0]
    runs = [
        s
        for r in reports
        for s in (r.settings["runs"] if set(r.settings) == {"runs"} else [r.settings])
    ]
    return TablesReport(
        command="; ".join(r.command for r in reports),
        started=min(r.started for r in reports),
        machine=first.machine,
        radio=first.radio,
        settings={"runs": runs} if len(runs) > 1 else first.settings,
        table1=_latest(row for r in reports for row in r.table1),
        table2=_latest(row for r in reports for row in r.table2),
        table3=_latest(row for r in reports for row in r.table3),
        wall_s=sum(r.wall_s for r in reports),
        cut_short="; ".join(f"{r.command}: {r.cut_short}" for r in reports if r.cut_short),
    )
