"""``actorswarm bench scale``: what the swarm size costs, in each membership scheme
(:mod:`actorswarm.bench.scale`).

A line per cell as it completes; the report to stdout, and to ``--out`` (Markdown),
``--json`` and ``--plot`` (PNG). The JSON is rewritten after every cell, marked "in
progress", so a run of hours that is cut short keeps what it measured; interrupted (Ctrl-C,
SIGTERM), a run writes its report so far, marked as such, before it exits.
"""

from __future__ import annotations

import json
import math
import shlex
from dataclasses import replace
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.console import Console
from rich.markup import escape

from actorswarm.cli.bench_tables import (
    Membership,
    interrupted,
    memberships,
    unwind_on_sigterm,
    write_whole,
)
from actorswarm.cli.common import output_paths

if TYPE_CHECKING:
    from actorswarm.bench.scale import ScaleCell, ScaleReport

__all__ = ["Cadence", "bench_scale", "cadences", "parse_bitrate", "register"]

# No wrapping: a line per row stays one line in a log file.
console = Console(stderr=True, soft_wrap=True)


def parse_sizes(text: str, high: int) -> list[int]:
    """``--sizes``: comma-separated integers in 2..``high``, ascending, without repeats;
    ``typer.BadParameter`` naming the option and the value otherwise."""
    parts = [p.strip() for p in text.split(",") if p.strip()]
    try:
        values = sorted({int(p) for p in parts})
    except ValueError:
        raise typer.BadParameter(
            f"--sizes {text!r}: expected comma-separated integers, e.g. 10,100,1000"
        ) from None
    if not values or any(v < 2 or v > high for v in values):
        raise typer.BadParameter(f"--sizes {text!r}: every size must be 2..{high}")
    return values


def parse_losses(text: str) -> list[float]:
    """``--loss``: comma-separated rates in [0, 1) (``0.1`` or ``10%``), ascending."""
    parts = [p.strip() for p in text.split(",") if p.strip()]
    try:
        values = sorted({float(p.rstrip("%")) / (100 if p.endswith("%") else 1) for p in parts})
    except ValueError:
        raise typer.BadParameter(
            f"--loss {text!r}: expected comma-separated loss rates, e.g. 0,0.1"
        ) from None
    if not values or any(not 0.0 <= v < 1.0 for v in values):
        raise typer.BadParameter(f"--loss {text!r}: every rate must be at least 0 and below 1")
    return values


_PREFIXES = {"k": 1e3, "m": 1e6, "g": 1e9}
#: The channel's defaults (those of ``Scenario``, after ``sim.radio.Airtime``).
_OVERHEAD = 28
_MAX_QUEUE = 1.0


def parse_bitrate(text: str) -> float:
    """``--channel-bitrate``: bits per second, a positive finite number, optionally with a
    k, M or G suffix (``1000000``, ``1e6``, ``1M``, ``250k``); ``typer.BadParameter``
    naming the option and the value otherwise."""
    body = text.strip()
    scale = _PREFIXES.get(body[-1:].lower(), 1.0)
    if scale != 1.0:
        body = body[:-1].strip()
    try:
        value = float(body) * scale
    except ValueError:
        raise typer.BadParameter(
            f"--channel-bitrate {text!r}: expected bits per second, e.g. 1000000, 1e6 or 1M"
        ) from None
    if not math.isfinite(value) or value <= 0:
        raise typer.BadParameter(
            f"--channel-bitrate {text!r}: must be a positive, finite number of bits per second"
        )
    return value


class Cadence(StrEnum):
    """``--cadence``: whether the core knows the channel (its members then slow down)."""

    on = "on"
    off = "off"
    both = "both"


def cadences(choice: Cadence | None, bitrate: float | None) -> tuple[bool, ...]:
    """The rows' cadences, off before on; by default on with a channel, off without.
    ``typer.BadParameter`` for a cadence without a channel to fit."""
    if choice is None:
        return (bitrate is not None,)
    if choice is not Cadence.off and bitrate is None:
        raise typer.BadParameter(
            f"--cadence {choice.value}: needs --channel-bitrate (the channel the members' "
            "heartbeats are to fit)"
        )
    return {Cadence.on: (True,), Cadence.off: (False,), Cadence.both: (False, True)}[choice]


def bench_scale(
    sizes: Annotated[
        str, typer.Option(help="Comma-separated swarm sizes, 2..10000.")
    ] = "10,100,1000",
    membership: Annotated[
        Membership,
        typer.Option(
            help="The core's membership scheme: star (members heartbeat to the master only), "
            "broadcast (everyone to everyone) or both (every size in each)."
        ),
    ] = Membership.both,
    loss: Annotated[
        str, typer.Option(help="Comma-separated loss rates (0.1 or 10%), each a row.")
    ] = "0",
    seed: Annotated[int, typer.Option(help="Seed of every row (the same in either scheme).")] = 1,
    max_wall: Annotated[
        float,
        typer.Option(
            min=1.0,
            help="Wall-clock seconds a row may take; past it the row is abandoned and "
            "reported as over budget, with the virtual time it reached.",
        ),
    ] = 600.0,
    quiet_from: Annotated[
        float, typer.Option(help="Virtual s: the quiet window (traffic, false leaves) begins.")
    ] = 2.0,
    barrier_at: Annotated[
        float,
        typer.Option(help="Virtual s: the quiet window ends; every platform asks for a barrier."),
    ] = 4.0,
    crash_at: Annotated[float, typer.Option(help="Virtual s: the master crashes.")] = 6.0,
    end: Annotated[float, typer.Option(help="Virtual s: the run ends.")] = 8.0,
    member_crash_at: Annotated[
        float | None,
        typer.Option(
            help="Virtual s, between the barrier and the master's crash: the member with the "
            "highest ID crashes, and the master's time to declare it gone is measured."
        ),
    ] = None,
    channel_bitrate: Annotated[
        str | None,
        typer.Option(
            metavar="BPS",
            help="Put the swarm on one shared radio channel of this many bit/s (1000000, "
            "1e6, 1M, 250k): each packet occupies it for its bytes plus --overhead-bytes; "
            "what would wait more than --max-queue for it is dropped. Default: no channel.",
        ),
    ] = None,
    overhead_bytes: Annotated[
        int,
        typer.Option(
            min=0,
            help="With --channel-bitrate: bytes each packet carries on the air besides "
            "its payload (28: the IPv4 and UDP headers).",
        ),
    ] = _OVERHEAD,
    max_queue: Annotated[
        float,
        typer.Option(
            min=0.0,
            help="With --channel-bitrate: seconds a packet may wait for the channel before "
            "it is dropped.",
        ),
    ] = _MAX_QUEUE,
    cadence: Annotated[
        Cadence | None,
        typer.Option(
            help="With --channel-bitrate: on (the core knows the channel: a star master slows "
            "its members' heartbeats to fit half of it), off (10 Hz whatever the channel) or "
            "both (each row twice). Default: on with a channel, off without.",
        ),
    ] = None,
    out: Annotated[Path | None, typer.Option(help="Write the Markdown report here.")] = None,
    json_out: Annotated[
        Path | None, typer.Option("--json", help="Write every figure as JSON here.")
    ] = None,
    plot: Annotated[Path | None, typer.Option(help="Draw the results as a PNG here.")] = None,
) -> None:
    """What the swarm size costs in each membership scheme (simulated, virtual time).

    N platforms form a swarm, pass one barrier of all and lose their master: wall time,
    formation, release, failover, packets per second in a quiet steady state and false
    leaves, per scheme, size and loss rate — optionally on one shared radio channel, with or
    without the members' heartbeats paced to it."""
    from actorswarm.bench.scale import MAX_SIZE, Scenario, run_scale

    size_list = parse_sizes(sizes, MAX_SIZE)
    losses = parse_losses(loss)
    bitrate = None if channel_bitrate is None else parse_bitrate(channel_bitrate)
    rows = cadences(cadence, bitrate)
    if bitrate is None and (overhead_bytes != _OVERHEAD or max_queue != _MAX_QUEUE):
        # Refused rather than ignored: a run without a channel would not be what was asked.
        raise typer.BadParameter("--overhead-bytes and --max-queue need --channel-bitrate")
    try:
        scenario = Scenario(
            quiet_from=quiet_from,
            barrier_at=barrier_at,
            crash_at=crash_at,
            end=end,
            max_wall=max_wall,
            member_crash_at=member_crash_at,
            channel_bitrate=bitrate,
            overhead_bytes=overhead_bytes,
            max_queue_s=max_queue,
        )
    except ValueError as exc:
        raise typer.BadParameter(str(exc)) from None
    schemes = memberships(membership)
    # Every option spelled out, defaults included: the report names exactly what it ran.
    args = ["--sizes", ",".join(map(str, size_list)), "--membership", membership.value]
    args += ["--loss", ",".join(f"{v:g}" for v in losses), "--seed", str(seed)]
    args += ["--max-wall", f"{max_wall:g}", "--quiet-from", f"{quiet_from:g}"]
    args += ["--barrier-at", f"{barrier_at:g}", "--crash-at", f"{crash_at:g}", "--end", f"{end:g}"]
    if member_crash_at is not None:
        args += ["--member-crash-at", f"{member_crash_at:g}"]
    if bitrate is not None:
        args += ["--channel-bitrate", f"{bitrate:g}", "--overhead-bytes", str(overhead_bytes)]
        args += ["--max-queue", f"{max_queue:g}"]
        args += ["--cadence", "both" if len(rows) == 2 else "on" if rows[0] else "off"]
    for flag, path in (("--out", out), ("--json", json_out), ("--plot", plot)):
        args += [flag, str(path)] if path is not None else []
    command = "actorswarm bench scale " + shlex.join(args)
    output_paths({"--out": out, "--json": json_out, "--plot": plot})
    total = len(size_list) * len(losses) * len(schemes) * len(rows)
    saved: list[ScaleReport] = []

    def done(report: ScaleReport, cell: ScaleCell) -> None:
        saved[:] = [report]
        console.print(f"[{len(report.cells)}/{total}] {_line(cell)}")
        if json_out is not None:
            _save_json(replace(report, cut_short="in progress"), json_out)

    unwind_on_sigterm()
    try:
        with console.status("starting") as status:
            report = run_scale(
                schemes,
                size_list,
                losses,
                seed=seed,
                scenario=scenario,
                command=command,
                cadences=rows,
                progress=status.update,
                done=done,
            )
    except (KeyboardInterrupt, SystemExit) as exc:
        if saved:
            cut = saved[0]
            cut.cut_short = f"{interrupted(exc, console)} after {len(cut.cells)} row(s)"
            _write(cut, out, json_out, plot)
        raise
    _write(report, out, json_out, plot)


def _line(cell: ScaleCell) -> str:
    """One cell, as the console line printed when it completes."""

    def fig(value: float, unit: str, digits: int = 0) -> str:
        return "—" if math.isnan(value) else f"{value:,.{digits}f}{unit}"

    text = (
        f"{escape(cell.label)}: {cell.wall_s:.1f} s wall ({cell.sim_per_wall:.3g} sim s/wall s); "
        f"formed at {fig(cell.formed_at_s, ' s', 2)}; released {cell.released}/{cell.expected}; "
        f"failover {fig(cell.failover_ms, ' ms')}; rx pkt/s: non-master "
        f"{fig(cell.member_recv_pps, '', 1)}, master {fig(cell.master_recv_pps, '')}"
    )
    if cell.channel_bitrate is not None:
        busy = cell.channel_utilisation
        text += (
            f"; channel {'—' if math.isnan(busy) else f'{busy:.0%}'} busy, "
            f"{fig(cell.channel_pps, '', 0)} pkt/s carried, {cell.run_airtime_drops:,} "
            f"airtime drops; member heartbeat {fig(cell.member_cadence_ms, ' ms')}"
        )
    if not math.isnan(cell.member_leave_ms):
        text += f"; member leave {fig(cell.member_leave_ms, ' ms')}"
    if cell.over_budget:
        return f"{text} [yellow]over budget at t = {cell.reached_s:.2f} s[/yellow]"
    if cell.errors:
        return f"{text} [yellow]{len(cell.errors)} problem(s)[/yellow]"
    return text


def _save_json(report: ScaleReport, path: Path) -> None:
    from actorswarm.bench.scale import to_json

    write_whole(path, json.dumps(to_json(report), indent=1, allow_nan=False) + "\n")


def _write(report: ScaleReport, out: Path | None, json_out: Path | None, plot: Path | None) -> None:
    from actorswarm.bench.scale_report import markdown, plot_scale, problems

    text = markdown(report)
    typer.echo(text)
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text)
        console.print(f"report written to {out}")
    if json_out is not None:
        _save_json(report, json_out)
        console.print(f"JSON written to {json_out}")
    if plot is not None:
        plot_scale(report, plot)
        console.print(f"picture written to {plot}")
    issues = problems(report)
    if issues:
        console.print(f"[yellow]{len(issues)} problem(s); see “What did not work”.[/yellow]")


def register(app: typer.Typer) -> None:
    """Add ``scale`` to the ``bench`` command group."""
    app.command("scale")(bench_scale)
