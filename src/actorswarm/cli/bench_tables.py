"""``actorswarm bench table1|table2|table3|all``: the paper's Tables I–III, reproduced in the
simulator and with real daemons, reported next to the paper's figures.

The plan of a run (which rows, how many repetitions) is built first and drawn as a progress
bar over every repetition; the report goes to stdout, and with ``--out DIR`` to
``DIR/tables.md``, ``DIR/tables.json`` and ``DIR/tables.png``. The JSON (``--json FILE``,
``--out DIR``) is rewritten after every row, marked "in progress", so a run of hours that is
cut short keeps what it measured; interrupted (Ctrl-C, SIGTERM), a run writes its whole
report so far, marked as such, before it exits.
"""

from __future__ import annotations

import inspect
import json
import shlex
import signal
import sys
import tempfile
import time
import typing
from collections.abc import Callable
from dataclasses import asdict, replace
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from actorswarm.cli.common import output_paths

if TYPE_CHECKING:
    from actorswarm.bench.tables import Plan, TablesReport
    from actorswarm.core.config import MembershipKind

__all__ = ["register"]

console = Console(stderr=True)


class Mode(StrEnum):
    sim = "sim"
    real = "real"
    both = "both"


class Membership(StrEnum):
    star = "star"
    broadcast = "broadcast"
    both = "both"


def memberships(choice: Membership) -> tuple[MembershipKind, ...]:
    """The membership schemes ``--membership`` asks for, in the order they are measured."""
    if choice is Membership.both:
        return ("star", "broadcast")
    return ("star",) if choice is Membership.star else ("broadcast",)


TABLES = {"table1": ("1",), "table2": ("2",), "table3": ("3",), "all": ("1", "2", "3")}


def _ints(text: str, low: int, high: int, *, empty: bool = False) -> list[int]:
    parts = [p.strip() for p in text.split(",") if p.strip()]
    if not parts and empty:
        return []
    try:
        values = sorted({int(p) for p in parts})
    except ValueError:
        raise typer.BadParameter(f"expected comma-separated integers, got {text!r}") from None
    if not values or any(v < low or v > high for v in values):
        raise typer.BadParameter(f"every value must be {low}..{high}, got {text!r}")
    return values


def _losses(text: str) -> list[float]:
    parts = [p.strip() for p in text.split(",") if p.strip()]
    try:
        values = sorted({float(p.rstrip("%")) / (100 if p.endswith("%") else 1) for p in parts})
    except ValueError:
        raise typer.BadParameter(f"expected comma-separated loss rates, got {text!r}") from None
    if any(not 0.0 < v < 1.0 for v in values):
        raise typer.BadParameter(f"every loss rate must be above 0 and below 1, got {text!r}")
    return values


def bench_tables(
    which: Annotated[str, typer.Argument(metavar="TABLE", help="table1, table2, table3 or all.")],
    sizes: Annotated[
        str | None,
        typer.Option(help="Swarm sizes of Tables II and III (default 5,10,15,20,25,30)."),
    ] = None,
    plugins: Annotated[
        str | None, typer.Option(help="Plugins per actor (Tables I, II) (default 1,5).")
    ] = None,
    repeat: Annotated[
        int | None, typer.Option(min=1, max=1000, help="Repetitions of each test (default 10).")
    ] = None,
    mode: Annotated[
        Mode, typer.Option(help="sim (virtual time), real (daemons over Zenoh) or both.")
    ] = Mode.both,
    big_sizes: Annotated[
        str | None,
        typer.Option(
            help="Beyond the paper, simulator only: sizes of II(a) and III "
            "(default 100,1000; '' for none)."
        ),
    ] = None,
    big_repeat: Annotated[
        int | None, typer.Option(min=1, help="Repetitions at sizes ≥ 100 (default 3).")
    ] = None,
    loss: Annotated[
        str | None,
        typer.Option(
            help="Beyond the paper, simulator only: loss rates of II(a) and III at every "
            "size (default 0.1,0.3; '' for none)."
        ),
    ] = None,
    peers: Annotated[
        int | None,
        typer.Option(min=1, max=200, help="Table I: the platform's peers (default 30)."),
    ] = None,
    window: Annotated[
        float | None, typer.Option(min=0.5, help="Table I: seconds per repetition (default 10).")
    ] = None,
    seed: Annotated[int, typer.Option(help="Seed of every random choice.")] = 1,
    cases: Annotated[
        str,
        typer.Option(
            help="Table II: switch (II(a), also at the big sizes and loss rates), branch "
            "(II(b)) or both, comma-separated."
        ),
    ] = "switch,branch",
    membership: Annotated[
        Membership,
        typer.Option(
            help="Simulated rows of Tables II and III: the core's membership scheme — star "
            "(members heartbeat to the master only), broadcast (everyone to everyone) or "
            "both (every row measured in each). Table I and real daemons run the default."
        ),
    ] = Membership.star,
    quick: Annotated[
        bool,
        typer.Option(
            "--quick",
            help="A smoke run in under two minutes: sizes 3,5, one plugin, 2 repetitions, "
            "10 % loss only, no big sizes, Table I with 3 peers and 2 s windows.",
        ),
    ] = False,
    out: Annotated[
        Path | None,
        typer.Option(help="Write tables.md, tables.json and tables.png into this directory."),
    ] = None,
    json_out: Annotated[
        Path | None, typer.Option("--json", help="Write the results as JSON here ('-': stdout).")
    ] = None,
    directory: Annotated[
        Path | None,
        typer.Option("--dir", help="Real mode: keep the daemons' state and logs here."),
    ] = None,
) -> None:
    """Reproduce the paper's Tables I–III next to its figures (median, p95 and range over
    the repetitions; the paper's means and our ratio to them)."""
    if which not in TABLES:
        raise typer.BadParameter(f"expected one of {', '.join(TABLES)}, got {which!r}")
    if which == "table1" and membership is not Membership.star:
        # Table I runs the core's default: say so rather than measure something else.
        raise typer.BadParameter(
            f"--membership {membership.value}: only Tables II and III choose the scheme"
        )
    from actorswarm.bench.tables import Plan

    plan = Plan(
        tables=TABLES[which],
        modes=("sim", "real") if mode is Mode.both else (mode.value,),
        sizes=_ints(sizes or ("3,5" if quick else "5,10,15,20,25,30"), 2, 10_000),
        big_sizes=_ints(
            big_sizes if big_sizes is not None else ("" if quick else "100,1000"),
            2,
            10_000,
            empty=True,
        ),
        plugins=_ints(plugins or ("1" if quick else "1,5"), 1, 20),
        losses=_losses(loss if loss is not None else ("0.1" if quick else "0.1,0.3")),
        repeat=repeat or (2 if quick else 10),
        big_repeat=big_repeat or (1 if quick else 3),
        peers=peers or (3 if quick else 30),
        window=window or (2.0 if quick else 10.0),
        seed=seed,
        cases=_cases(cases),
        memberships=memberships(membership),
    )
    output_paths({"--out": out, "--json": json_out, "--dir": directory}, dirs=("--out", "--dir"))
    command = "actorswarm bench " + shlex.join(sys.argv[2:])  # '' stays visible

    unwind_on_sigterm()
    saved: list[TablesReport] = []

    def checkpoint(report: TablesReport) -> None:
        saved[:] = [report]
        _save_json(report, out, json_out, "in progress")

    try:
        with tempfile.TemporaryDirectory(prefix="actorswarm-tables-") as scratch:
            report = run(plan, command, directory or Path(scratch), checkpoint)
    except (KeyboardInterrupt, SystemExit) as exc:
        if saved:
            _write(_cut(saved[0], interrupted(exc, console)), out, json_out)
        raise
    _write(report, out, json_out)


def unwind_on_sigterm() -> None:
    """SIGTERM unwinds like Ctrl-C: the daemons started so far are killed on the way out,
    and the rows so far are written."""

    def terminated(signum: int, frame: object) -> None:
        raise SystemExit(128 + signum)

    signal.signal(signal.SIGTERM, terminated)


def interrupted(exc: KeyboardInterrupt | SystemExit, console: Console) -> str:
    """Why a run stops short ("interrupted (Ctrl-C)"), said on ``console`` first."""
    why = "Ctrl-C" if isinstance(exc, KeyboardInterrupt) else f"exit {exc.code}"
    console.print(f"[yellow]interrupted ({why}): writing the rows so far[/yellow]")
    return f"interrupted ({why})"


def write_whole(path: Path, text: str) -> None:
    """``text`` into ``path``, written whole and renamed: a reader never sees half a file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    part = path.with_name(path.name + ".part")
    part.write_text(text)
    part.replace(path)


def _cases(text: str) -> tuple[str, ...]:
    cases = tuple(c.strip() for c in text.split(",") if c.strip())
    wrong = [c for c in cases if c not in ("switch", "branch")]
    if wrong or not cases:
        raise typer.BadParameter(
            f"--cases {text!r}: expected switch, branch or both (comma-separated)"
        )
    return cases


def _cut(report: TablesReport, why: str) -> TablesReport:
    """``report`` marked as not a finished run: why, and how many rows it has."""
    rows = len(report.table1) + len(report.table2) + len(report.table3)
    return replace(report, cut_short=f"{why} after {rows} row(s)")


def _save_json(report: TablesReport, out: Path | None, json_out: Path | None, why: str) -> None:
    """The rows so far as JSON where the run's JSON goes (not stdout), marked ``why``."""
    from actorswarm.bench.tables import to_json

    targets = [p for p in (json_out,) if p is not None and str(p) != "-"]
    targets += [out / "tables.json"] if out is not None else []
    if not targets:
        return
    data = json.dumps(to_json(_cut(report, why)), indent=1) + "\n"
    for path in targets:
        write_whole(path, data)


def run(
    plan: Plan,
    command: str,
    directory: Path,
    checkpoint: Callable[[TablesReport], None] = lambda report: None,
) -> TablesReport:
    """Every measurement of ``plan`` (the simulator's first, then real daemons'), with a
    progress bar; the :class:`TablesReport`. ``checkpoint`` is called with the report so far
    after every row."""
    from actorswarm.bench.daemons import machine_info
    from actorswarm.bench.tables import Backend, TablesReport, measure
    from actorswarm.bench.tables_real import DaemonBackend
    from actorswarm.bench.tables_sim import SimBackend, radio_model

    simulator = SimBackend(plan.settings(), big_repeat=plan.big_repeat)
    backends: list[Backend] = [simulator, DaemonBackend(plan.settings(), directory)]
    units = sum(b.units(plan) for b in backends if b.mode in plan.modes)
    report = TablesReport(
        command=command,
        started=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        machine=machine_info(),
        radio=radio_model(simulator),
        settings=asdict(plan),
    )
    began = time.perf_counter()
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
    )
    with Progress(*columns, console=console, transient=True) as bar:
        task = bar.add_task("starting", total=units)

        said = [0.0]

        def progress(message: str, *, advance: int = 0) -> None:
            bar.update(task, description=message[:70], advance=advance)
            # Not a terminal (a CI log, nohup): no bar is drawn, so a line every 10 s.
            if not console.is_terminal and time.monotonic() - said[0] >= 10.0:
                said[0] = time.monotonic()
                done = int(bar.tasks[0].completed)
                console.print(f"[{done}/{units}] {time.perf_counter() - began:.0f} s: {message}")

        def row_done() -> None:
            report.wall_s = time.perf_counter() - began
            checkpoint(report)

        measure(plan, backends, report, progress, row_done)
    report.wall_s = time.perf_counter() - began
    return report


def bench_report(
    results: Annotated[
        list[Path],
        typer.Argument(
            help="JSON files written by bench table*/all (--json or --out); FILE:sim or "
            "FILE:real takes only that mode's rows of FILE.",
            metavar="RUN.json[:MODE]...",
        ),
    ],
    out: Annotated[
        Path | None,
        typer.Option(help="Write tables.md, tables.json and tables.png into this directory."),
    ] = None,
    json_out: Annotated[
        Path | None, typer.Option("--json", help="Write the merged JSON here ('-': stdout).")
    ] = None,
) -> None:
    """Report saved runs again, merged into one (to put runs made apart — real daemons, the
    simulator at 1000 platforms — in one report and one picture). A row measured again in a
    later file (same table, mode, size, plugins, loss) replaces the earlier one."""
    from actorswarm.bench.tables import MODES, from_json, merge

    output_paths({"--out": out, "--json": json_out}, dirs=("--out",))
    reports = []
    for spec in results:
        path, _, only = str(spec).rpartition(":")
        if only not in MODES:  # no ":sim"/":real" suffix: every row of the file
            path, only = str(spec), ""
        try:
            report = from_json(json.loads(Path(path).read_text()))
        except OSError as exc:
            raise typer.BadParameter(f"{path}: {exc.strerror or exc}") from None
        except (ValueError, KeyError, TypeError, AttributeError) as exc:
            raise typer.BadParameter(f"{path}: not a bench tables result ({exc!r})") from None
        if only:
            report.table1 = [r for r in report.table1 if r.mode == only]
            report.table2 = [r for r in report.table2 if r.mode == only]
            report.table3 = [r for r in report.table3 if r.mode == only]
            report.command += f"  (its {only} rows)"
        reports.append(report)
    merged = merge(reports)
    replaced = sum(len(r.table1) + len(r.table2) + len(r.table3) for r in reports) - (
        len(merged.table1) + len(merged.table2) + len(merged.table3)
    )
    if replaced:
        console.print(f"{replaced} row(s) measured again in a later file replace the earlier")
    _write(merged, out, json_out)


def _write(report: TablesReport, out: Path | None, json_out: Path | None) -> None:
    from actorswarm.bench.tables import to_json
    from actorswarm.bench.tables_plot import plot_tables
    from actorswarm.bench.tables_report import markdown, problems

    text = markdown(report)
    data = json.dumps(to_json(report), indent=1) + "\n"
    if json_out is not None and str(json_out) == "-":
        typer.echo(data, nl=False)
    else:
        typer.echo(text)
    if json_out is not None and str(json_out) != "-":
        json_out.parent.mkdir(parents=True, exist_ok=True)
        json_out.write_text(data)
        console.print(f"JSON written to {json_out}")
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        (out / "tables.md").write_text(text)
        (out / "tables.json").write_text(data)
        plot_tables(report, out / "tables.png")
        console.print(f"report, JSON and picture written to {out}/tables.{{md,json,png}}")
    failed = problems(report)
    if failed:
        console.print(f"[yellow]{len(failed)} problem(s); see “What did not work”.[/yellow]")


def _command(which: str, help_text: str) -> Callable[..., None]:
    """``bench_tables`` with ``which`` fixed: the options of every table command are the
    same, declared once."""

    def command(**kwargs: Any) -> None:
        bench_tables(which, **kwargs)

    # Evaluated annotations: the options' Annotated metadata is what typer reads.
    signature = inspect.signature(bench_tables, eval_str=True)
    command.__signature__ = signature.replace(  # type: ignore[attr-defined]
        parameters=[p for name, p in signature.parameters.items() if name != "which"]
    )
    hints = typing.get_type_hints(bench_tables, include_extras=True)
    command.__annotations__ = {k: v for k, v in hints.items() if k != "which"}
    command.__doc__ = help_text
    return command


def register(app: typer.Typer) -> None:
    """Add ``table1``, ``table2``, ``table3`` and ``all`` to the ``bench`` command group."""
    for name, what in (
        ("table1", "Table I: one platform's CPU and memory, and the single Actor switch."),
        ("table2", "Table II: collective switch and branch — time, packets/s, bytes/packet."),
        ("table3", "Table III: the master's daemon killed → a new master acknowledged by all."),
        ("all", "Tables I, II and III, next to the paper's figures."),
    ):
        app.command(name)(_command(name, what))
    app.command("report")(bench_report)
