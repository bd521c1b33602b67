"""``actorswarm task verify SCRIPT``: the user's mission under many seeded fault schedules.

The command reads and checks everything before the first run (the script, the world, the
profile, the schedule, the output places, the Ray cluster), so bad input costs nothing and
leaves nothing behind; then it runs, shows progress, minimizes each failure class and
reports (:mod:`actorswarm.sim.verify`). Ctrl-C stops the runs and reports what finished.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

if TYPE_CHECKING:
    from actorswarm.sim.verify.pool import Pool
    from actorswarm.sim.verify.profile import FaultProfile
    from actorswarm.sim.verify.runner import Mission
    from actorswarm.sim.verify.schedule import Schedule
    from actorswarm.sim.verify.session import Outcome

__all__ = ["register"]

#: Exit status when the runs were interrupted (Ctrl-C), as a shell reports SIGINT.
EXIT_INTERRUPTED = 130


def _refuse(message: str) -> typer.Exit:
    typer.echo(message, err=True)
    return typer.Exit(2)


def task_verify(
    file: Annotated[Path, typer.Argument(help="The task script to verify.")],
    world: Annotated[
        Path | None,
        typer.Option(help="World description (TOML); default: the script's sim line's."),
    ] = None,
    no_world: Annotated[
        bool, typer.Option("--no-world", help="Protocol and plugins only, no vehicles.")
    ] = False,
    runs: Annotated[int, typer.Option(min=1, max=1_000_000, help="Runs to make.")] = 100,
    seed: Annotated[
        int, typer.Option(min=0, help="Seed of the first run (the others: the next ones).")
    ] = 0,
    faults: Annotated[
        Path | None,
        typer.Option(metavar="PROFILE.toml", help="Fault profile (TOML) over the default profile."),
    ] = None,
    event: Annotated[
        list[str] | None,
        typer.Option(
            metavar="NAME@T[:IDS]",
            help="An operator's event (default: those of the script's sim line).",
        ),
    ] = None,
    duration: Annotated[
        float | None,
        typer.Option(min=0.1, help="Virtual seconds per run (default: the sim line's, or 30)."),
    ] = None,
    done: Annotated[
        str | None,
        typer.Option(
            metavar="ACTORS",
            help="A run completed when every platform ends in one of these actors "
            "(comma-separated; default: the actors without transitions); in one the "
            "script starts in, only once it switched into it (a loop came round).",
        ),
    ] = None,
    require: Annotated[
        float | None,
        typer.Option(
            min=0.0,
            max=1.0,
            metavar="P",
            help="Exit 1 when the completion rate's 95 % lower bound is under P, or any "
            "invariant was violated or separation breached.",
        ),
    ] = None,
    workers: Annotated[
        int | None,
        typer.Option(min=1, help="Processes on this machine.", show_default="every CPU"),
    ] = None,
    ray: Annotated[
        str | None,
        typer.Option(
            metavar="ADDRESS",
            help="Run on the Ray cluster at HOST:PORT (or ray://HOST:PORT, auto, local); "
            "needs actorswarm[ray].",
        ),
    ] = None,
    min_separation: Annotated[
        float | None,
        typer.Option(
            metavar="M", min=0.01, help="Every pair of airborne vehicles keeps M metres (as sim)."
        ),
    ] = None,
    budget: Annotated[
        int,
        typer.Option(
            min=0,
            max=10_000,
            help="Re-runs spent minimizing each failure class (0: no minimizing).",
        ),
    ] = 48,
    json_out: Annotated[
        str | None, typer.Option("--json", help="Write the JSON report here ('-': stdout).")
    ] = None,
    report: Annotated[
        Path | None,
        typer.Option(
            metavar="DIR",
            help="Write an HTML report with plots and each failure class's MCAP recording here.",
        ),
    ] = None,
) -> None:
    """Try a task script under many seeded fault schedules before it flies.

    Each run is the script in the simulator under one fault schedule drawn from the profile
    (radio loss and delay, platforms killed and rebooted — the master among them —,
    partitions, autopilots late or refusing, batteries draining faster, the operator's
    events early or late). Failures are grouped by where they went wrong; each group's
    schedule is minimized to the faults it needs, with the one `actorswarm sim` command
    that replays it. Exit status: 0; 1 with --require when the completion rate's lower
    bound is under P or an invariant was violated; 2 for unusable input; 130 when
    interrupted (the report so far is printed).
    """
    from actorswarm.sim.campaign_runner import default_workers
    from actorswarm.sim.verify.pool import Pool, RayUnavailable, check_ray_address
    from actorswarm.sim.verify.session import schedules

    if ray is not None and workers is not None:
        raise _refuse("--ray and --workers exclude each other (Ray places the runs itself)")
    if ray is not None:
        try:
            check_ray_address(ray)
        except ValueError as exc:
            raise _refuse(str(exc)) from None
    mission, profile = _prepare(
        file, world, no_world, faults, event, duration, min_separation, done
    )
    if json_out not in (None, "-"):
        from actorswarm.cli.common import output_file

        output_file(Path(json_out), "--json")
    if report is not None:
        _check_report_dir(report)
    try:
        pool = Pool(workers=workers or default_workers(), ray=ray)
    except RayUnavailable as exc:
        raise _refuse(str(exc)) from None
    from actorswarm.sim.verify.runner import platforms_of

    platforms = sorted(platforms_of(mission))
    planned = schedules(mission, profile, seed, runs, platforms)
    try:
        outcome = _run(mission, profile, planned, pool, budget)
        recordings = {} if report is None or outcome.interrupted else _record(outcome, pool)
    finally:
        pool.close()
    _finish(outcome, json_out, report, recordings, require)


def _prepare(
    file: Path,
    world: Path | None,
    no_world: bool,
    faults: Path | None,
    event: list[str] | None,
    duration: float | None,
    min_separation: float | None,
    done: str | None,
) -> tuple[Mission, FaultProfile]:
    """The mission and the profile, every input checked (exit 2 naming what is wrong)."""
    from actorswarm.cli.common import check_script
    from actorswarm.dsl import DEFAULT_MAX_BYTES
    from actorswarm.sim.tasksim import parse_event
    from actorswarm.sim.verdict import schedule_problems
    from actorswarm.sim.verify.profile import DEFAULT_PROFILE, ProfileError, load_profile
    from actorswarm.sim.verify.runner import Mission, looping
    from actorswarm.sim.verify.scenario import scenario_of
    from actorswarm.world.config import WorldError, load_world

    if no_world and world is not None:
        raise _refuse("--world and --no-world exclude each other")
    try:
        text = file.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise _refuse(f"{file}: cannot read the file: {exc}") from None
    try:
        scenario = scenario_of(text, file)
    except ValueError as exc:
        raise _refuse(f"{file}: {exc}") from None
    if scenario is not None and world is None and not no_world:
        world, no_world = scenario.world, scenario.no_world
    try:
        profile = DEFAULT_PROFILE if faults is None else load_profile(faults)
    except ProfileError as exc:
        raise _refuse(str(exc)) from None
    except OSError as exc:
        raise _refuse(f"--faults {faults}: cannot read the file: {exc.strerror or exc}") from None
    world_config = None
    world_text = None
    if not no_world:
        try:
            world_config = load_world(world)
        except (WorldError, OSError) as exc:
            raise _refuse(str(exc)) from None
        world_text = None if world is None else world.read_text(encoding="utf-8")
    areas = None if world_config is None else [a.name for a in world_config.areas]
    _, script = check_script(file, DEFAULT_MAX_BYTES, areas, world_config)
    if script is None:
        typer.echo(f"{file}: the script must pass `actorswarm task check` first", err=True)
        raise typer.Exit(2)
    try:
        events = [parse_event(e) for e in event] if event else None
    except ValueError as exc:
        raise _refuse(str(exc)) from None
    if events is None:
        events = list(scenario.events) if scenario is not None else []
    if duration is None:
        duration = scenario.duration if scenario and scenario.duration else 30.0
    base_faults = scenario.faults if scenario is not None else ()
    problems = schedule_problems(script, duration, events, base_faults)
    if problems:
        for problem in problems:
            typer.echo(problem, err=True)
        raise typer.Exit(2)
    problems = profile.problems(script.platform_ids())
    if problems:
        for problem in problems:
            typer.echo(problem, err=True)
        raise typer.Exit(2)
    if no_world and min_separation is not None:
        raise _refuse("--min-separation needs vehicles: leave out --no-world")
    goal = _actors(done, [a.name for a in script.actors])
    mission = Mission(
        script_text=text,
        script_path=str(file),
        world_text=world_text,
        world_path=None if world is None else str(world),
        duration=duration,
        events=tuple(events),
        no_world=no_world,
        min_separation=min_separation,
        faults=tuple(base_faults),
        done=goal,
        came_back=looping(script, goal),
    )
    return mission, profile


def _actors(text: str | None, known: list[str]) -> tuple[str, ...]:
    """``--done``'s actor names, each one of the script's (exit 2 naming one that is not)."""
    from actorswarm.suggest import did_you_mean

    if text is None:
        return ()
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    if not names:
        raise _refuse("--done: name at least one actor")
    for name in names:
        if name not in known:
            raise _refuse(
                f"--done: the script has no actor {name!r}{did_you_mean(name, known)}; its "
                f"actors: {', '.join(known)}"
            )
    return names


def _check_report_dir(report: Path) -> None:
    """``--report DIR`` must be creatable: its parent a writable directory, itself a
    directory or absent (it is replaced whole at the end)."""
    import os

    if report.exists() and not report.is_dir():
        raise _refuse(f"--report {report}: is a file; give a directory")
    parent = report.resolve().parent
    if not parent.is_dir():
        raise _refuse(f"--report {report}: {parent} is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise _refuse(f"--report {report}: cannot write in {parent}; choose another place")


def _run(
    mission: Mission, profile: FaultProfile, planned: list[Schedule], pool: Pool, budget: int
) -> Outcome:
    from rich.console import Console

    from actorswarm.cli.progress import tally
    from actorswarm.sim.verify.runner import RunResult
    from actorswarm.sim.verify.session import FailureClass, verify

    console = Console(stderr=True)
    total = len(planned)
    typer.echo(f"{total} run(s) of {mission.script_path} on {pool.describe()}", err=True)
    began = time.perf_counter()
    with tally(console, total, "runs") as progress:

        def on_result(result: RunResult) -> None:
            progress.count(result.ok)

        def on_minimized(cls: FailureClass) -> None:
            m = cls.minimized
            if m is not None:
                typer.echo(
                    f"minimized {cls.signature!r}: {m.original} -> {len(m.schedule.items)} "
                    f"fault(s) in {m.reruns} re-runs",
                    err=True,
                )

        outcome = verify(
            mission,
            profile,
            planned,
            pool,
            on_result=on_result,
            on_minimized=on_minimized,
            budget=budget,
            minimize_classes=budget > 0,
        )
    outcome.wall_s = time.perf_counter() - began
    outcome.where = pool.describe()
    return outcome


def _record(outcome: Outcome, pool: Pool) -> dict[int, Path]:
    """Each failure class's smallest failing run, recorded to MCAP in a private temporary
    directory (the report directory takes them in at the end)."""
    import tempfile

    if not outcome.classes:
        return {}
    folder = Path(tempfile.mkdtemp(prefix="actorswarm-verify-"))
    jobs = []
    for i, cls in enumerate(outcome.classes, start=1):
        schedule = cls.minimized.schedule if cls.minimized else cls.schedule
        jobs.append((outcome.mission, schedule, str(folder / f"class-{i}.mcap")))
    made: dict[int, Path] = {}
    try:
        for index, path in pool.map(record_one, jobs):
            made[index + 1] = Path(path)
    except KeyboardInterrupt:
        outcome.interrupted = True
    except Exception as exc:  # a recording that cannot be made is said, not fatal
        typer.echo(f"the failure recordings could not all be made: {exc}", err=True)
    return made


def record_one(mission: Mission, schedule: Schedule, path: str) -> str:
    """Run ``schedule`` again and write it to the MCAP file ``path`` (what ``sim
    --record`` writes for the same command); ``path``."""
    from actorswarm.recording import write_simulation
    from actorswarm.sim.record import sample_world
    from actorswarm.sim.verify.runner import build

    sim = build(mission, schedule)
    packets: list[tuple[float, int]] = []
    if sim.world is not None:
        sample_world(sim, 0.5, packets)
    faults = mission.all_faults(schedule)
    report = sim.run(mission.duration, events=schedule.ground_events(), faults=faults)
    world = sim.world
    write_simulation(
        path,
        report,
        meta={
            "script": sim.script.name,
            "seed": schedule.seed,
            "sim_time_s": report["sim_time_s"],
            "source": "actorswarm sim",
        },
        track=None if world is None else world.track(),
        areas=None if world is None else world.area_polygons(),
        script=(Path(mission.script_path).name, mission.script_text),
        packets=packets,
        faults=faults,
    )
    return path


def _finish(
    outcome: Outcome,
    json_out: str | None,
    report: Path | None,
    recordings: dict[int, Path],
    require: float | None,
) -> None:
    from actorswarm.sim.verify.report import as_json, summary_lines, write_report_dir

    if report is not None:
        write_report_dir(outcome, report, recordings)
    data = as_json(outcome, require=require)
    if json_out == "-":
        typer.echo(json.dumps(data, indent=2))
    else:
        if json_out is not None:
            Path(json_out).write_text(json.dumps(data, indent=2) + "\n")
        for line in summary_lines(outcome):
            typer.echo(line)
        if report is not None:
            typer.echo(f"report: {report / 'index.html'}")
    if outcome.interrupted:
        raise typer.Exit(EXIT_INTERRUPTED)
    if require is not None:
        low, _ = outcome.completion_interval()
        if low < require or outcome.violations():
            typer.echo(
                f"--require {require:g}: the completion rate's 95 % lower bound is {low:.3f}"
                + (f"; {outcome.violations()} run(s) violated an invariant or separation"
                   if outcome.violations() else ""),
                err=True,
            )  # fmt: skip
            raise typer.Exit(1)


def register(task_app: typer.Typer) -> None:
    task_app.command("verify")(task_verify)
