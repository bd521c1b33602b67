"""The ``actorswarm`` command line.

Commands so far: ``swarm demo`` (a simulated swarm losing its master mid-barrier and being
partitioned, with every invariant checked), ``swarm campaign`` (the seeded fault campaign, or
one replayed seed) and ``bench core`` (the collective-core benchmark of DESIGN.md §8).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from actorswarm import __version__

app = typer.Typer(
    help="actorswarm: program robot swarms as Actors.",
    no_args_is_help=True,
    add_completion=False,
)
swarm_app = typer.Typer(help="Simulated swarms of the collective core.", no_args_is_help=True)
bench_app = typer.Typer(help="Benchmarks (DESIGN.md §8).", no_args_is_help=True)
app.add_typer(swarm_app, name="swarm")
app.add_typer(bench_app, name="bench")

console = Console()
err = Console(stderr=True)


@app.command()
def version() -> None:
    """Print the version."""
    console.print(f"actorswarm {__version__}")


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

    report = run_demo(size=size, seed=seed, loss=loss, latency=latency / 1000.0, console=console)
    if json_out is not None:
        json_out.write_text(json.dumps(report, indent=2, default=str))
        console.print(f"JSON report written to {json_out}")
    if report["violations"] or report["problems"]:
        raise typer.Exit(1)


@swarm_app.command("campaign")
def swarm_campaign(
    seed: Annotated[
        int | None, typer.Option(help="Replay this one seed, printing its schedule.")
    ] = None,
    start: Annotated[int, typer.Option(min=0, help="First seed of a campaign.")] = 0,
    count: Annotated[int, typer.Option(min=1, help="Number of seeds.")] = 200,
) -> None:
    """Run seeded random fault schedules and check every invariant and the recovery."""
    from actorswarm.sim.campaign import make_case, run_case

    seeds = [seed] if seed is not None else list(range(start, start + count))
    failed = 0
    with console.status("running fault schedules") as status:
        for s in seeds:
            status.update(f"seed {s} ({seeds.index(s) + 1}/{len(seeds)}), {failed} failed")
            case = make_case(s)
            if seed is not None:
                console.print(case.describe())
            result = run_case(case)
            if not result.ok:
                failed += 1
                console.print(result.explain(), markup=False)
    console.print(f"{len(seeds) - failed} passed, {failed} failed")
    if failed:
        raise typer.Exit(1)


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
) -> None:
    """Barrier latency, traffic and failover time in virtual time, per swarm size."""
    from actorswarm.bench.core import bench_size, markdown, to_json
    from actorswarm.core.config import CoreConfig

    try:
        size_list = [int(s) for s in sizes.split(",") if s.strip()]
    except ValueError:
        err.print(f"--sizes: expected comma-separated integers, got {sizes!r}")
        raise typer.Exit(2) from None
    if not size_list or any(n < 2 or n > 5000 for n in size_list):
        err.print(f"--sizes: every size must be 2..5000, got {sizes!r}")
        raise typer.Exit(2)
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


def main() -> None:
    app()
