"""``actorswarm launch SWARM.toml``: start the daemons a launch file names on this machine,
show them live, restart one on request, stop them all on Ctrl-C.

The file's format is in :mod:`actorswarm.launch.config`; how the daemons are run, watched
and stopped in :mod:`actorswarm.launch.runner`. A problem with the file or the keys is
reported before anything starts, with exit status 2.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Annotated

import typer

__all__ = ["launch"]


def launch(
    file: Annotated[Path, typer.Argument(help="The launch file (TOML).")],
    check: Annotated[
        bool,
        typer.Option("--check", help="Check the file and print each daemon's command; start none."),
    ] = False,
    restart: Annotated[
        int | None,
        typer.Option(
            metavar="ID",
            help="Ask the launcher already running this file to restart platform ID, and exit.",
        ),
    ] = None,
    interval: Annotated[
        float, typer.Option(min=0.2, help="Seconds between two refreshes of the table.")
    ] = 1.0,
) -> None:
    """Start a swarm of daemons on this machine from one file and show them live.

    Type `r ID` and Enter (or run `actorswarm launch FILE --restart ID` elsewhere) to
    restart one from its state directory; Ctrl-C (or `q`) stops them all cleanly."""
    from rich.console import Console

    from actorswarm.cli.swarm_setup import packet_guard, refuse
    from actorswarm.launch import LaunchError, load_launch
    from actorswarm.launch.runner import Launcher, request

    try:
        plan = load_launch(file)
    except LaunchError as exc:
        raise refuse(str(exc)) from None
    if restart is not None:
        if restart not in plan.platforms:
            raise refuse(f"--restart {restart}: not one of the platforms of {file}")
        problem = request(plan.directory, f"r {restart}")
        if problem is not None:
            raise refuse(problem)
        typer.echo(f"asked the launcher of {file} to restart platform {restart}")
        return
    keys = None
    if not plan.insecure:
        from actorswarm.security import default_key_dir

        keys = plan.keys or default_key_dir()
        packet_guard(keys, False, "platform")  # exit 2 with the hint when they are unusable
    console = Console()
    launcher = Launcher(plan, keys, console)
    if check:
        for p in plan.plans:
            typer.echo(" ".join(launcher.swarm.command(p.platform, *plan.daemon_args(p))))
        if plan.autopilots is not None:
            for index, platform in enumerate(plan.mavlink_platforms()):
                argv = plan.autopilots.argv(index, platform)
                typer.echo(
                    f"autopilot {platform}: " + ("attach" if argv is None else " ".join(argv))
                )
        return
    if _may_read_stdin():
        launcher.listen(sys.stdin)
    raise typer.Exit(launcher.run(live=console.is_terminal, interval=interval))


def _may_read_stdin() -> bool:
    """Whether requests can be read from standard input: a pipe or file, or the terminal
    when the launcher runs in its foreground (a background job that reads the terminal is
    stopped by SIGTTIN; it then takes requests through ``--restart`` only)."""
    try:
        fd = sys.stdin.fileno()
    except (AttributeError, OSError, ValueError):
        return False
    if not os.isatty(fd):
        return True
    try:
        return os.tcgetpgrp(fd) == os.getpgrp()
    except OSError:
        return False
