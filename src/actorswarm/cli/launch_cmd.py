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
from typing import TYPE_CHECKING, Annotated

import typer

if TYPE_CHECKING:
    from actorswarm.launch.runner import Launcher

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
    _check_ports(launcher, file)
    _gs_settings(launcher, keys)
    if _may_read_stdin():
        launcher.listen(sys.stdin)
    raise typer.Exit(launcher.run(live=console.is_terminal, interval=interval))


def _check_ports(launcher: Launcher, file: Path) -> None:
    """Refuse (exit 2, before any daemon starts) when a port the launch needs is taken: a
    daemon would otherwise die at start with the error in its log only."""
    from actorswarm.cli.swarm_setup import busy_endpoint, refuse

    wanted = [("ports", e) for e in launcher.swarm.endpoints]
    web = launcher.plan.web
    if web is not None:
        wanted.append(("web", f"tcp/127.0.0.1:{web}"))
    for key, endpoint in wanted:
        problem = busy_endpoint(endpoint)
        if problem is not None:
            raise refuse(f"{file}: {problem}; choose other {key} in the file (or free the port)")


def _gs_settings(launcher: Launcher, keys: Path | None) -> None:
    """Write the ground station's settings of this swarm as a profile next to the daemons'
    files and print the ``gs`` lines that reach it."""
    import shlex

    from actorswarm.cli.profile import profile_text

    plan = launcher.plan
    endpoints = list(launcher.swarm.endpoints)
    profile = plan.directory / "gs-profile.toml"
    profile.parent.mkdir(parents=True, exist_ok=True)
    profile.write_text(
        profile_text(plan.swarm, endpoints, plan.multicast, keys, plan.insecure), encoding="utf-8"
    )
    args = ["--swarm", plan.swarm, "--multicast" if plan.multicast else "--no-multicast"]
    for endpoint in endpoints:
        args += ["--connect", endpoint]
    args += ["--insecure"] if plan.insecure else ["--keys", str(keys)] if keys else []
    typer.echo(f"ground station of this swarm: actorswarm gs status {shlex.join(args)}")
    typer.echo(
        f"  or, with its settings in {profile}: actorswarm gs --profile {profile} status "
        f"(or export ACTORSWARM_PROFILE={profile})"
    )


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
