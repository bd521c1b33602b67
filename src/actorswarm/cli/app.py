"""The ``actorswarm`` command line.

Commands so far: ``swarm demo`` (a simulated swarm losing its master mid-barrier and being
partitioned, with every invariant checked), ``swarm campaign`` (the seeded fault campaign, or
one replayed seed) and ``bench core`` (the collective-core benchmark of docs/design.md §8);
``task check`` and ``task graph`` for task scripts (docs/design.md §4, §7); ``launch`` for
several daemons from one file.
"""

from __future__ import annotations

import json
import sys
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.console import Console

from actorswarm import __version__
from actorswarm.cli.common import (
    check_script,
    output_dir,
    output_file,
    output_paths,
    read_world,
)
from actorswarm.cli.errors import guard_commands
from actorswarm.cli.help_format import plain_help
from actorswarm.cli.record_cmd import (
    LIVE_PORT,
    LiveHostOpt,
    LiveOpt,
    LivePortOpt,
    OriginOpt,
    record_app,
)
from actorswarm.cli.web_cmd import (
    DEFAULT_HOST,
    DEFAULT_PORT,
    HostOpt,
    PortOpt,
    ServeOpt,
    SpeedOpt,
    TokenOpt,
)
from actorswarm.dsl import DEFAULT_MAX_BYTES, to_dot, to_mermaid

if TYPE_CHECKING:
    from actorswarm.core.config import MembershipKind

app = typer.Typer(
    help="actorswarm: program robot swarms as Actors.\n\n"
    "Exit status 2, with one line on stderr saying what and what to do: the command could "
    "not run as given (an option, a file that cannot be read or written, a port in use, "
    "unusable keys). Each command's help lists its other statuses.",
    no_args_is_help=True,
    add_completion=False,
)
swarm_app = typer.Typer(help="Simulated swarms of the collective core.", no_args_is_help=True)
bench_app = typer.Typer(help="Benchmarks (docs/design.md §8).", no_args_is_help=True)
task_app = typer.Typer(
    help="Task scripts (docs/design.md §4): check them, draw their Actor state machine, "
    "verify them under seeded faults.",
    no_args_is_help=True,
)
app.add_typer(swarm_app, name="swarm")
app.add_typer(bench_app, name="bench")
app.add_typer(task_app, name="task")


def _register_real_swarm() -> None:
    """``daemon`` and ``gs``: imported here so the commands exist, their heavy imports
    (Zenoh) happen only when they run."""
    from actorswarm.cli.autopilot_cmd import autopilot
    from actorswarm.cli.daemon_cmd import daemon
    from actorswarm.cli.gs import gs_app
    from actorswarm.cli.gs_control import register
    from actorswarm.cli.keys import keys_app

    app.command("daemon")(daemon)
    app.command("autopilot")(autopilot)
    from actorswarm.cli.launch_cmd import launch

    app.command("launch")(launch)
    from actorswarm.cli.bench_tables import register as register_tables

    register_tables(bench_app)
    from actorswarm.cli.bench_scale import register as register_scale

    register_scale(bench_app)
    register(gs_app)
    from actorswarm.cli.web_cmd import register as register_web

    register_web(gs_app)
    from actorswarm.cli.gs_record import register as register_record

    register_record(gs_app)
    from actorswarm.ros2.gs_cmd import register as register_ros2

    register_ros2(gs_app)
    from actorswarm.cli.verify_cmd import register as register_verify

    register_verify(task_app)
    app.add_typer(gs_app, name="gs")
    app.add_typer(keys_app, name="keys")
    app.add_typer(record_app, name="record")


_register_real_swarm()

console = Console()


def _int_list(text: str, flag: str, low: int, high: int) -> list[int]:
    """A comma-separated list of integers in low..high, or a clear error and exit 2."""
    try:
        values = [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        typer.echo(f"{flag}: expected comma-separated integers, got {text!r}", err=True)
        raise typer.Exit(2) from None
    if not values or any(v < low or v > high for v in values):
        typer.echo(f"{flag}: every value must be {low}..{high}, got {text!r}", err=True)
        raise typer.Exit(2)
    return values


@app.command()
def version() -> None:
    """Print the version."""
    console.print(f"actorswarm {__version__}")


def _print_version(asked: bool) -> None:
    if asked:
        typer.echo(f"actorswarm {__version__}")
        raise typer.Exit(0)


@app.callback()
def _root(
    show_version: Annotated[
        bool,
        typer.Option(
            "--version",
            is_eager=True,
            callback=_print_version,
            help="Print the version and exit.",
        ),
    ] = False,
) -> None:
    """actorswarm: program robot swarms as Actors."""


@swarm_app.command("demo")
def swarm_demo(
    size: Annotated[int, typer.Option(min=2, max=200, help="Platforms in the swarm.")] = 10,
    seed: Annotated[int, typer.Option(help="Seed of the radio and the workload.")] = 1,
    loss: Annotated[float, typer.Option(min=0.0, max=0.9, help="Packet loss probability.")] = 0.1,
    latency: Annotated[float, typer.Option(min=0.0, help="One-way latency, ms.")] = 10.0,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write a JSON report.")] = None,
) -> None:
    """A simulated swarm: election, barriers, a role, the master crashing mid-barrier, a
    restart, a partition with two masters, the heal — with every invariant checked."""
    from actorswarm.sim.demo import run_demo

    output_paths({"--json": json_out})
    report = run_demo(size=size, seed=seed, loss=loss, latency=latency / 1000.0, console=console)
    if json_out is not None:
        json_out.write_text(json.dumps(report, indent=2, default=str))
        console.print(f"JSON report written to {json_out}")
    if report["violations"] or report["problems"]:
        raise typer.Exit(1)


class CampaignMembership(StrEnum):
    """Membership modes of ``swarm campaign``: one of the core's, or both."""

    star = "star"
    broadcast = "broadcast"
    both = "both"


@swarm_app.command("campaign")
def swarm_campaign(
    seed: Annotated[
        int | None, typer.Option(help="Replay this one seed, printing its schedule.")
    ] = None,
    start: Annotated[int, typer.Option(min=0, help="First seed of a campaign.")] = 0,
    count: Annotated[int, typer.Option(min=1, help="Number of seeds.")] = 200,
    membership: Annotated[
        CampaignMembership,
        typer.Option(help="Membership mode of the core; both: every seed in each mode."),
    ] = CampaignMembership.star,
    workers: Annotated[
        int | None,
        typer.Option(min=1, help="Worker processes.", show_default="the number of CPUs"),
    ] = None,
    renew: Annotated[
        bool,
        typer.Option(
            "--renew",
            help="Renewable barrier requests, as the task engine makes them, and a barrier "
            "of one platform at a time (another run of the same schedules).",
        ),
    ] = False,
) -> None:
    """Run seeded random fault schedules and check every invariant and the recovery.

    Each failure is printed as it comes, with the command that replays it;
    the last line counts the cases that passed and failed, with the wall time.
    Exit status 1 when any case failed.
    """
    import time

    from actorswarm.sim.campaign import MEMBERSHIPS, check_membership

    modes = (
        MEMBERSHIPS
        if membership is CampaignMembership.both
        else (check_membership(membership.value),)
    )
    began = time.perf_counter()
    if seed is not None:
        failed = _replay_seed(seed, modes, renew)
        total = len(modes)
    else:
        from actorswarm.sim.campaign_runner import default_workers

        total = count * len(modes)
        failed = _run_campaign(
            start, count, modes, workers or default_workers(), began, renew=renew
        )
    wall = time.perf_counter() - began
    console.print(f"{total - failed} passed, {failed} failed in {wall:.1f} s")
    if failed:
        raise typer.Exit(1)


def _replay_seed(seed: int, modes: tuple[MembershipKind, ...], renew: bool = False) -> int:
    """Run one seed in each of ``modes`` here, printing its schedule; the failures."""
    from actorswarm.sim.campaign import make_case, run_case

    failed = 0
    for mode in modes:
        case = make_case(seed, mode, renew=renew)
        console.print(case.describe(), markup=False, soft_wrap=True)
        with console.status(f"running seed {seed} ({mode})"):
            result = run_case(case)
        if not result.ok:
            failed += 1
            console.print(result.explain(), markup=False, soft_wrap=True)
    return failed


def _run_campaign(
    start: int,
    count: int,
    modes: tuple[MembershipKind, ...],
    workers: int,
    began: float,
    *,
    renew: bool = False,
) -> int:
    """Run seeds ``start..start+count-1`` in each of ``modes`` on ``workers`` processes,
    printing failures as they come and the progress (a bar on a terminal, otherwise a line
    every 10 s); the number of failures. Ctrl-C stops it with exit status 130 after saying
    how far it got."""
    import time

    from actorswarm.cli.progress import tally
    from actorswarm.sim.campaign import CaseResult
    from actorswarm.sim.campaign_runner import run_campaign

    total = count * len(modes)
    console.print(
        f"{total} cases: seeds {start}..{start + count - 1} in {' and '.join(modes)} "
        f"membership, {workers} worker(s)"
    )
    with tally(console, total, "cases") as progress:

        def on_result(result: CaseResult) -> None:
            if not result.ok:
                console.print(result.explain(), markup=False, soft_wrap=True)
            progress.count(result.ok)

        try:
            run_campaign(start, count, modes, workers=workers, on_result=on_result, renew=renew)
        except KeyboardInterrupt:
            progress.bar.stop()
            console.print(
                f"interrupted: {progress.done - progress.failed} passed, {progress.failed} "
                f"failed of {total} in {time.perf_counter() - began:.1f} s"
            )
            raise typer.Exit(130) from None
    return progress.failed


@bench_app.command("core")
def bench_core(
    sizes: Annotated[
        str, typer.Option(help="Comma-separated swarm sizes.")
    ] = "5,10,20,30,100,1000",
    repeats: Annotated[int, typer.Option(min=1, help="Repetitions per size up to 100.")] = 5,
    big_repeats: Annotated[int, typer.Option(min=1, help="Repetitions above 100.")] = 1,
    latency: Annotated[float, typer.Option(min=0.1, help="One-way latency, ms.")] = 10.0,
    loss: Annotated[float, typer.Option(min=0.0, max=0.5, help="Loss of the lossy runs.")] = 0.05,
    adaptive_retry: Annotated[
        bool, typer.Option(help="First retransmission delay from measured round trips.")
    ] = False,
    out: Annotated[Path | None, typer.Option(help="Write the Markdown table here.")] = None,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write raw results.")] = None,
    plot: Annotated[Path | None, typer.Option(help="Draw the results as a PNG here.")] = None,
) -> None:
    """Barrier latency, traffic and failover time in virtual time, per swarm size."""
    from actorswarm.bench.core import bench_size, markdown, to_json
    from actorswarm.core.config import CoreConfig

    size_list = _int_list(sizes, "--sizes", 2, 5000)
    output_paths({"--out": out, "--json": json_out, "--plot": plot})
    config = CoreConfig(adaptive_retry=adaptive_retry)
    results = []
    with console.status("benchmarking") as status:
        for n in size_list:
            reps = repeats if n <= 100 else big_repeats
            result = bench_size(
                n,
                repeats=reps,
                latency=latency / 1000.0,
                loss=loss,
                config=config,
                progress=status.update,
            )
            results.append(result)
            console.print(f"N={n}: done in {result.wall_s:.1f} s wall")
    command = "actorswarm bench core " + " ".join(sys.argv[3:]) if len(sys.argv) > 3 else ""
    text = markdown(results, latency=latency / 1000.0, loss=loss, config=config)
    console.print(text, markup=False)
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        header = f"Command: `{command or 'actorswarm bench core'}`\n\n"
        out.write_text(header + text)
        console.print(f"written to {out}")
    if json_out is not None:
        json_out.write_text(json.dumps(to_json(results), indent=2))
    if plot is not None:
        from actorswarm.bench.plot import plot_core

        plot_core(results, plot, latency=latency / 1000.0, loss=loss, t_leave=config.t_leave)
        console.print(f"picture written to {plot}")


@bench_app.command("daemons")
def bench_daemons(
    sizes: Annotated[
        str | None, typer.Option(help="Comma-separated swarm sizes [default: 10,30].")
    ] = None,
    quick: Annotated[
        bool,
        typer.Option("--quick", help="Sizes 5,10, 2 failovers and 2 switches, 5 s CPU windows."),
    ] = False,
    failovers: Annotated[
        int | None, typer.Option(min=0, help="Master kills per size [default: 10].")
    ] = None,
    switches: Annotated[
        int | None, typer.Option(min=0, help="Collective switches per size [default: 10].")
    ] = None,
    window: Annotated[
        float | None, typer.Option(min=0.5, help="CPU window, seconds [default: 20].")
    ] = None,
    directory: Annotated[
        Path | None,
        typer.Option(
            "--dir", help="Keep the daemons' keys, state and logs here (default: a temp dir)."
        ),
    ] = None,
    out: Annotated[Path | None, typer.Option(help="Write the Markdown report here.")] = None,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write every run here.")] = None,
    broadcast: Annotated[
        str,
        typer.Option(
            help="How broadcasts travel: mesh (TCP links between every pair) or multicast "
            "(Zenoh's UDP multicast transport on --group through --interface)."
        ),
    ] = "mesh",
    group: Annotated[
        str, typer.Option(help="The multicast group, ADDRESS:PORT (--broadcast multicast).")
    ] = "224.0.0.225:7448",
    interface: Annotated[
        str, typer.Option(help="The multicast group's interface (--broadcast multicast).")
    ] = "lo",
    lease: Annotated[
        float | None,
        typer.Option(min=0.1, max=3600, help="Zenoh's session lease, seconds [default: 30]."),
    ] = None,
    daemons_from: Annotated[
        Path | None,
        typer.Option(
            help="Run the daemons from this source checkout (its src/) instead of this one: "
            "the code before a change, measured by the same harness."
        ),
    ] = None,
) -> None:
    """Real daemon processes on loopback: CPU and memory, packets on the wire, master
    failover, collective switch (docs/design.md §8). Loads the machine: every daemon is a
    process on its cores. Run it in a network namespace of its own (`ip netns exec`) for
    the packet counts to be the swarm's alone."""
    import signal
    import tempfile

    from actorswarm.bench.daemons import (
        Settings,
        SizeResult,
        bench,
        daemons_env,
        markdown,
        to_json,
    )

    size_list = _int_list(sizes or ("5,10" if quick else "10,30"), "--sizes", 2, 200)
    from actorswarm.transport.zenoh_transport import BROADCASTS, check_group, check_interface

    try:
        if broadcast not in BROADCASTS:
            raise ValueError(f"--broadcast {broadcast!r}: " + " or ".join(BROADCASTS))
        group = check_group(group)
        check_interface(interface)
        if daemons_from is not None:
            daemons_env(daemons_from)
    except ValueError as exc:
        typer.echo(str(exc), err=True)
        raise typer.Exit(2) from None
    output_paths({"--out": out, "--json": json_out, "--dir": directory}, dirs=("--dir",))
    settings = Settings(
        broadcast=broadcast,
        group=group,
        interface=interface,
        lease=lease,
        daemons_from=None if daemons_from is None else str(daemons_from),
        window=window if window is not None else (5.0 if quick else 20.0),
        failovers=failovers if failovers is not None else (2 if quick else 10),
        switches=switches if switches is not None else (2 if quick else 10),
    )
    command = " ".join(["actorswarm bench daemons", *sys.argv[3:]])

    def done(r: SizeResult) -> None:
        problems = len(r.errors) + sum(1 for f in r.failover if f.error)
        problems += sum(1 for w in r.switch if w.error)
        console.print(
            f"N={r.size}: done in {r.wall_s:.0f} s"
            + (f", [red]{problems} problem(s)[/red]" if problems else "")
        )

    def terminated(signum: int, frame: object) -> None:
        # Unwind like Ctrl-C, so the daemons started so far are killed on the way out.
        raise SystemExit(128 + signum)

    signal.signal(signal.SIGTERM, terminated)
    with tempfile.TemporaryDirectory(prefix="actorswarm-bench-") as scratch:
        where = directory or Path(scratch)
        with console.status("benchmarking real daemons") as status:
            result = bench(
                where, size_list, settings, command=command, progress=status.update, done=done
            )
    text = markdown(result)
    typer.echo(text)
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text)
        console.print(f"written to {out}")
    if json_out is not None:
        json_out.parent.mkdir(parents=True, exist_ok=True)
        json_out.write_text(json.dumps(to_json(result), indent=2) + "\n")
    failed = any(r.errors or any(f.error for f in r.failover) for r in result.sizes)
    if failed or any(w.error for r in result.sizes for w in r.switch):
        raise typer.Exit(1)


@bench_app.command("switch")
def bench_switch(
    plugins: Annotated[str, typer.Option(help="Comma-separated plugins per actor.")] = "1,5",
    runs: Annotated[int, typer.Option(min=10, help="Switches measured per row.")] = 1000,
    out: Annotated[Path | None, typer.Option(help="Write the Markdown table here.")] = None,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write the rows here.")] = None,
) -> None:
    """Single-platform Actor switch time, cold and warm (docs/design.md §8)."""
    from actorswarm.bench.switch import markdown, run, to_json

    counts = _int_list(plugins, "--plugins", 1, 64)
    output_paths({"--out": out, "--json": json_out})
    rows = run(counts, runs)
    text = markdown(rows)
    typer.echo(text)
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(f"Command: `actorswarm bench switch {' '.join(sys.argv[3:])}`\n\n{text}")
    if json_out is not None:
        json_out.write_text(json.dumps(to_json(rows), indent=2))


@bench_app.command("plot")
def bench_plot(
    results: Annotated[Path, typer.Argument(help="JSON written by bench core --json.")],
    out: Annotated[Path, typer.Option(help="The PNG to write.")],
    latency: Annotated[float, typer.Option(min=0.1, help="One-way latency of the run, ms.")] = 10.0,
    loss: Annotated[float, typer.Option(min=0.0, max=0.5, help="Loss of its lossy runs.")] = 0.05,
) -> None:
    """Redraw a saved ``bench core`` run without running it again."""
    from actorswarm.bench.core import from_json
    from actorswarm.bench.plot import plot_core
    from actorswarm.core.config import CoreConfig

    try:
        rows = json.loads(results.read_text())
        if not isinstance(rows, list) or not rows:
            raise ValueError("expected a non-empty list of sizes")
        data = from_json(rows)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        typer.echo(f"{results}: not a bench core result file ({exc})", err=True)
        raise typer.Exit(2) from None
    output_file(out, "--out")
    plot_core(data, out, latency=latency / 1000.0, loss=loss, t_leave=CoreConfig().t_leave)
    console.print(f"picture written to {out}")


@app.command("sim")
def sim(
    file: Annotated[Path, typer.Argument(help="The task script to run.")],
    seed: Annotated[int, typer.Option(help="Seed of the radio and the platforms.")] = 0,
    loss: Annotated[
        float,
        typer.Option(
            min=0.0,
            max=0.9,
            help="Packet loss probability of every link; with a world, on top of its "
            "distance-based loss.",
        ),
    ] = 0.0,
    latency: Annotated[
        float,
        typer.Option(
            min=0.0,
            help="One-way latency of every link, ms; with a world, added to its "
            "distance-based latency.",
        ),
    ] = 10.0,
    jitter: Annotated[
        float, typer.Option(min=0.0, help="Extra random latency of every link, ms.")
    ] = 0.0,
    channel_bitrate: Annotated[
        float | None,
        typer.Option(
            metavar="BPS",
            help="Model one shared radio channel of this many bit/s (default: no airtime).",
        ),
    ] = None,
    duration: Annotated[float, typer.Option(min=0.1, help="Virtual seconds to run.")] = 30.0,
    event: Annotated[
        list[str] | None,
        typer.Option(
            metavar="NAME@T[:IDS]",
            help="A ground-station event NAME at T seconds (to platforms IDS; default every one).",
        ),
    ] = None,
    kill: Annotated[
        list[str] | None,
        typer.Option(
            metavar="IDS@T",
            help="Crash platforms IDS at T seconds (master@T: whichever is master then).",
        ),
    ] = None,
    restart: Annotated[
        list[str] | None,
        typer.Option(
            metavar="IDS@T",
            help="Reboot platforms IDS at T seconds (master@T: those the last --kill "
            "master@T crashed).",
        ),
    ] = None,
    partition: Annotated[
        list[str] | None,
        typer.Option(
            metavar="IDS[@T]",
            help="Cut platforms IDS off from the others at T seconds (default: from the start).",
        ),
    ] = None,
    heal: Annotated[
        list[str] | None, typer.Option(metavar="@T", help="End every partition at T seconds.")
    ] = None,
    late_ready: Annotated[
        list[str] | None,
        typer.Option(
            metavar="IDS@T",
            help="The autopilots of IDS are not ready to take off before T seconds (a "
            "take-off asked earlier waits).",
        ),
    ] = None,
    refuse_takeoff: Annotated[
        list[str] | None,
        typer.Option(
            metavar="IDS",
            help="The autopilots of IDS never arm: each take-off fails for good after 120 s "
            "with vehicle_fault_event.",
        ),
    ] = None,
    drain: Annotated[
        list[str] | None,
        typer.Option(
            metavar="IDS:FACTOR",
            help="The batteries of IDS drain FACTOR times faster than the world says.",
        ),
    ] = None,
    world: Annotated[Path | None, typer.Option(help="World description (TOML).")] = None,
    no_world: Annotated[
        bool, typer.Option("--no-world", help="Protocol and plugins only, no vehicles.")
    ] = False,
    json_out: Annotated[
        str | None, typer.Option("--json", help="Write the JSON report here ('-': stdout).")
    ] = None,
    record: Annotated[
        Path | None,
        typer.Option(
            help="Write the run here as an MCAP recording (Foxglove, web --replay, plot)."
        ),
    ] = None,
    live: LiveOpt = False,
    live_host: LiveHostOpt = "127.0.0.1",
    live_port: LivePortOpt = LIVE_PORT,
    origin: OriginOpt = None,
    serve: ServeOpt = False,
    host: HostOpt = DEFAULT_HOST,
    port: PortOpt = DEFAULT_PORT,
    token: TokenOpt = None,
    speed: SpeedOpt = 1.0,
    expect_complete: Annotated[
        bool,
        typer.Option(
            "--expect-complete",
            help="Exit 4 when the task has not completed by the end of the run.",
        ),
    ] = False,
    min_separation: Annotated[
        float | None,
        typer.Option(
            metavar="M",
            min=0.01,
            help="Every pair of airborne vehicles must keep at least M metres (over each "
            "kind's separation in the world), and a breach stops the run (exit 1).",
        ),
    ] = None,
) -> None:
    """Run a task script on a simulated swarm, in virtual time (docs/design.md §7).

    Exit status: 0 when the run went as asked; 1 when the script has errors or an invariant
    was violated; 2 when the command line cannot be run (a bad option or world file, an
    --event no transition handles, an --event or fault after --duration or naming a
    platform the script does not start); 3 when a plugin failed during the run; 4 with
    --expect-complete when the task did not complete. The summary says which.
    """
    from actorswarm.cli.record_cmd import (
        parse_origin_option,
        sim_live,
        write_sim_record,
    )
    from actorswarm.core.config import CoreConfig
    from actorswarm.runtime.actor_runtime import UnsupportedPlugin
    from actorswarm.runtime.plugin import ParamError
    from actorswarm.runtime.registry import RegistryError
    from actorswarm.sim.radio import Airtime, LinkModel
    from actorswarm.sim.record import sample_world
    from actorswarm.sim.tasksim import TaskSim, parse_event, parse_fault, summary
    from actorswarm.sim.vehicle_faults import parse_vehicle_fault
    from actorswarm.sim.verdict import EXIT_USAGE, schedule_problems, verdict
    from actorswarm.world.config import WorldConfig, WorldError, load_world

    if no_world and world is not None:
        typer.echo("--world and --no-world exclude each other", err=True)
        raise typer.Exit(2)
    if no_world and min_separation is not None:
        typer.echo("--min-separation needs vehicles: leave out --no-world", err=True)
        raise typer.Exit(2)
    world_config: WorldConfig | None = None
    if not no_world:
        try:
            world_config = load_world(world)  # None: the default world
        except (WorldError, OSError) as exc:
            typer.echo(str(exc), err=True)
            raise typer.Exit(2) from None
    # The world is known here, so the script's area names are checked against it.
    areas = None if world_config is None else [a.name for a in world_config.areas]
    code, script = check_script(file, DEFAULT_MAX_BYTES, areas, world_config)
    if script is None:
        raise typer.Exit(code or 1)
    try:
        events = [parse_event(e) for e in event or []]
        faults = [parse_fault("kill", k) for k in kill or []]
        faults += [parse_fault("restart", r) for r in restart or []]
        faults += [parse_fault("partition", p) for p in partition or []]
        faults += [parse_fault("heal", h) for h in heal or []]
        vehicle_faults = [parse_vehicle_fault("late", v) for v in late_ready or []]
        vehicle_faults += [parse_vehicle_fault("refuse", v) for v in refuse_takeoff or []]
        vehicle_faults += [parse_vehicle_fault("drain", v) for v in drain or []]
    except ValueError as exc:
        typer.echo(str(exc), err=True)
        raise typer.Exit(2) from None
    if vehicle_faults and world_config is None:
        typer.echo(
            "--late-ready, --refuse-takeoff and --drain need vehicles: leave out --no-world",
            err=True,
        )
        raise typer.Exit(2)
    if record is not None:
        output_file(record, "--record")
    if json_out not in (None, "-"):
        output_file(Path(json_out), "--json")
    problems = schedule_problems(script, duration, events, faults, vehicle_faults)
    for problem in problems:
        typer.echo(problem, err=True)
    if problems:
        raise typer.Exit(EXIT_USAGE)
    try:
        airtime = None if channel_bitrate is None else Airtime(bitrate=channel_bitrate)
    except ValueError as exc:
        typer.echo(f"--channel-bitrate: {exc}", err=True)
        raise typer.Exit(2) from None
    link = LinkModel(loss=loss, latency=latency / 1000.0, jitter=jitter / 1000.0)
    frame = parse_origin_option(origin)
    packets: list[tuple[float, int]] = []
    try:
        run = TaskSim(
            script,
            seed=seed,
            link=link,
            # The core knows the channel too: a star master then slows its members'
            # heartbeats to fit their share of it.
            config=CoreConfig(channel_bitrate=channel_bitrate),
            world_config=world_config,
            airtime=airtime,
            min_separation=min_separation,
            vehicle_faults=tuple(vehicle_faults),
        )
        if serve:
            from actorswarm.cli.web_cmd import serve_sim

            serve_sim(
                run,
                file,
                events=events,
                faults=faults,
                host=host,
                port=port,
                token=token,
                speed=speed,
            )
            return
        if (record is not None or live) and run.world is not None:
            sample_world(run, 0.5, packets)
        if live:
            meta = {"script": script.name, "seed": seed, "source": "actorswarm sim --live"}
            served = (live_host, live_port)
            report = sim_live(
                run, file, meta, duration, speed, events, faults, served, record, frame
            )
            record = None  # written as it ran
        else:
            report = run.run(duration, events=events, faults=faults)
    except (UnsupportedPlugin, RegistryError, ParamError) as exc:
        # What the checker cannot know (a plugin of a module:Class path, a param laid over
        # by a transition): refused here as cleanly.
        typer.echo(f"{file}: {exc}", err=True)
        raise typer.Exit(2) from None
    if record is not None:
        meta = {
            "script": script.name,
            "seed": seed,
            "sim_time_s": report["sim_time_s"],
            "source": "actorswarm sim",
        }
        write_sim_record(record, run, report, meta, file, frame, packets, faults)
    text = json.dumps(report, indent=2)
    if json_out == "-":
        typer.echo(text)
    else:
        if json_out is not None:
            Path(json_out).write_text(text + "\n")
        for line in summary(report):
            typer.echo(line)
    status, lines = verdict(report, expect_complete=expect_complete)
    for line in lines:
        typer.echo(line, err=True)
    raise typer.Exit(status)


@app.command("demo")
def demo(
    mission: Annotated[
        str, typer.Option(help="formation (the default), search-track or battery.")
    ] = "formation",
    platforms: Annotated[
        int | None, typer.Option(min=1, max=1000, help="Swarm size (default: the mission's).")
    ] = None,
    seed: Annotated[int, typer.Option(help="Seed of the radio and the platforms.")] = 0,
    loss: Annotated[
        float,
        typer.Option(
            min=0.0,
            max=0.9,
            help="Packet loss probability of every link, on top of the world's "
            "distance-based loss.",
        ),
    ] = 0.0,
    kill: Annotated[
        list[str] | None, typer.Option(metavar="IDS@T", help="Crash platforms IDS at T seconds.")
    ] = None,
    realtime: Annotated[
        bool, typer.Option("--realtime", help="Pace the run to the wall clock.")
    ] = False,
    out: Annotated[Path, typer.Option(help="Directory for pictures and files.")] = Path("demo-out"),
    serve: ServeOpt = False,
    host: HostOpt = DEFAULT_HOST,
    port: PortOpt = DEFAULT_PORT,
    token: TokenOpt = None,
    speed: SpeedOpt = 1.0,
) -> None:
    """The main job: a shipped mission in the simulator, with progress and pictures.

    Exit status, as ``sim --expect-complete`` gives it: 0 when the mission went as asked; 1
    when an invariant was violated; 2 on an unknown mission or a malformed --kill (nothing
    ran); 3 when a plugin failed during the run (each failure is listed); 4 when the
    mission did not complete. The summary says which.
    """
    from actorswarm.cli.demo import demo_status, run_demo
    from actorswarm.missions import mission as find_mission
    from actorswarm.sim.tasksim import parse_fault

    try:
        chosen = find_mission(mission)
        kills = tuple(
            (p, f.t) for f in (parse_fault("kill", k) for k in kill or []) for p in sorted(f.ids)
        )
    except (KeyError, ValueError) as exc:
        # A KeyError's str() is its repr: print the message itself.
        typer.echo(str(exc.args[0]) if exc.args else str(exc), err=True)
        raise typer.Exit(2) from None
    if not serve:
        output_dir(out, "--out")
    if serve:
        from actorswarm.cli.web_cmd import serve_mission

        serve_mission(
            chosen,
            platforms=platforms,
            seed=seed,
            loss=loss,
            kills=kills,
            host=host,
            port=port,
            token=token,
            speed=speed,
        )
        return
    report = run_demo(
        chosen,
        out=out,
        platforms=platforms,
        seed=seed,
        loss=loss,
        realtime=realtime,
        kills=kills,
        console=console,
    )
    status, lines = demo_status(report, console)
    for line in lines:
        typer.echo(line, err=True)
    raise typer.Exit(status)


@app.command("plot")
def plot(
    recording: Annotated[
        Path, typer.Argument(help="A recording (MCAP or JSON Lines) of sim, demo or gs record.")
    ],
    out: Annotated[Path, typer.Option(help="Directory for the pictures.")] = Path("."),
) -> None:
    """Draw a recorded run: trajectories (top view, coloured by actor) and the timeline."""
    from actorswarm.recording import read_recording
    from actorswarm.sim.record import RecordError
    from actorswarm.viz import timeline_png, trajectory_png

    try:
        data = read_recording(recording)
    except OSError as exc:
        typer.echo(f"{recording}: cannot read the recording: {exc.strerror or exc}", err=True)
        raise typer.Exit(2) from None
    except RecordError as exc:
        text = str(exc)
        typer.echo(text if str(recording) in text else f"{recording}: {text}", err=True)
        raise typer.Exit(2) from None
    for note in data.notes:
        typer.echo(f"{recording}: {note}", err=True)
    output_dir(out, "--out")
    stem = recording.stem
    for path in (
        trajectory_png(data, out / f"{stem}-trajectories.png"),
        timeline_png(data, out / f"{stem}-timeline.png"),
    ):
        typer.echo(f"wrote {path}")


def _register_web() -> None:
    from actorswarm.cli.web_cmd import web

    app.command("web")(web)


_register_web()


class GraphFormat(StrEnum):
    """Diagram languages of ``task graph``."""

    mermaid = "mermaid"
    dot = "dot"


@task_app.command("check")
def task_check(
    files: Annotated[list[Path], typer.Argument(metavar="FILE", help="Task scripts to check.")],
    max_bytes: Annotated[
        int, typer.Option(min=1, help="Refuse scripts larger than this many bytes.")
    ] = DEFAULT_MAX_BYTES,
    world: Annotated[
        Path | None,
        typer.Option(
            help="The world (TOML) the scripts will run in: check their area names, and warn "
            "about separation, the ceiling and crowded areas."
        ),
    ] = None,
) -> None:
    """Check task scripts before deploying them.

    Prints "FILE: ok" on stdout for each valid script; every problem goes to stderr as
    FILE:LINE:COL: message (warnings too, without failing). With --world, every area a
    plugin names must be one of that world's [[areas]], and what can be known of separation
    before flight is warned about (docs/safety.md). Exit status: 0 when every script
    is valid, 1 when any has an error, 2 when a file (or the world) cannot be read.
    """
    world_config = None if world is None else read_world(world)
    areas = None if world_config is None else [area.name for area in world_config.areas]
    status = 0
    for path in files:
        code, script = check_script(path, max_bytes, areas, world_config)
        if code == 0:
            typer.echo(f"{path}: ok")
        if script is not None and world_config is not None and world_config.radio.relay:
            from actorswarm.dsl.radio import homes_span

            span, groups = homes_span(script, world_config)
            if groups == 1:
                typer.echo(f"{path}: the platforms' homes span {span} radio hop(s), relayed")
        status = max(status, code)
    raise typer.Exit(status)


@task_app.command("graph")
def task_graph(
    file: Annotated[Path, typer.Argument(help="The task script to draw.")],
    fmt: Annotated[
        GraphFormat, typer.Option("--format", help="Mermaid stateDiagram-v2 or Graphviz dot.")
    ] = GraphFormat.mermaid,
    max_bytes: Annotated[
        int, typer.Option(min=1, help="Refuse scripts larger than this many bytes.")
    ] = DEFAULT_MAX_BYTES,
) -> None:
    """Print the Actor state machine of a task script as a diagram.

    Edges are labelled with the event, the share of sysNum, and the barrier key; timeout
    edges are marked (dashed in dot). A script with errors prints its diagnostics on stderr
    and exits 1 (2 when the file cannot be read).
    """
    code, script = check_script(file, max_bytes)
    if script is None:
        raise typer.Exit(code or 1)
    typer.echo(to_mermaid(script) if fmt is GraphFormat.mermaid else to_dot(script), nl=False)


# Last, after every command (and every group's) is registered: one line and exit status 2
# for the expected errors of any command (actorswarm.cli.errors).
guard_commands(app)
plain_help(app)


def main() -> None:
    app()
