"""The web ground station on the command line: ``actorswarm gs web``, ``--serve`` for
``actorswarm sim`` and ``actorswarm demo``, and ``actorswarm web --replay`` for a recording.

``gs web`` serves the page against a real swarm over Zenoh, with the same swarm, endpoint
and key options as the other ``gs`` commands; the state machine drawn is the script given
with ``--script``, or the one ``gs deploy`` deployed last. ``sim FILE --serve`` and ``demo
--serve`` serve the simulation instead of running it to the end: it runs paced to the wall
clock (``--speed`` virtual seconds per wall second) until the server is stopped, with the
scheduled events and faults still happening at their times.

The page binds to 127.0.0.1 unless ``--host`` says otherwise; on any other interface it
needs an access token (``--token``, or one is generated) and the address printed carries
it. The option types are exported so that the ``sim`` and ``demo`` commands declare the
same options; the web server's modules are imported only when a page is served.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from actorswarm.cli.swarm_options import LinkOptions, default_state_file, link_options

if TYPE_CHECKING:
    from actorswarm.dsl.model import TaskScript
    from actorswarm.missions import Mission
    from actorswarm.sim.tasksim import Fault, GroundEvent, TaskSim
    from actorswarm.web.source import SwarmSource

__all__ = [
    "DEFAULT_HOST",
    "DEFAULT_PORT",
    "HostOpt",
    "PortOpt",
    "ServeOpt",
    "SpeedOpt",
    "TokenOpt",
    "gs_web",
    "register",
    "serve_mission",
    "serve_sim",
    "web",
]

# The same values as actorswarm.web.server's, kept here so declaring the options does not
# import the web server.
DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8765
#: The shortest token accepted from the command line.
MIN_TOKEN = 12

ServeOpt = Annotated[
    bool,
    typer.Option(
        "--serve", help="Serve the web ground station on the run instead of running it to the end."
    ),
]
HostOpt = Annotated[
    str,
    typer.Option(help="Interface of the web ground station (any but the loopback needs a token)."),
]
PortOpt = Annotated[
    int, typer.Option(min=0, max=65535, help="Port of the web ground station (0: any free).")
]
TokenOpt = Annotated[
    str | None,
    typer.Option(
        help="Access token of the web ground station (default: none on 127.0.0.1, a random "
        "one elsewhere)."
    ),
]
SpeedOpt = Annotated[
    float,
    typer.Option(min=0.1, max=100.0, help="With --serve: virtual seconds per wall second."),
]


def _check_token(host: str, token: str | None) -> None:
    from actorswarm.web.access import is_loopback

    if token is not None and len(token) < MIN_TOKEN:
        typer.echo(f"--token: use at least {MIN_TOKEN} characters", err=True)
        raise typer.Exit(2)
    if not is_loopback(host) and token is None:
        typer.echo(
            f"--host {host}: the page will be reachable from the network; a random access "
            "token is made for it (give --token to choose one)",
            err=True,
        )


def _serve(source: SwarmSource, host: str, port: int, token: str | None) -> None:
    from actorswarm.web.server import serve

    _check_token(host, token)
    try:
        serve(source, host=host, port=port, token=token, announce=typer.echo)
    except OSError as exc:
        typer.echo(str(exc), err=True)
        raise typer.Exit(2) from None


def serve_sim(
    run: TaskSim,
    file: Path,
    *,
    events: Iterable[GroundEvent] = (),
    faults: Iterable[Fault] = (),
    host: str = DEFAULT_HOST,
    port: int = DEFAULT_PORT,
    token: str | None = None,
    speed: float = 1.0,
) -> None:
    """``actorswarm sim FILE --serve``: serve ``run`` (built from ``file``) until stopped.

    The run starts here (its time 0 happens before serving), so a script the simulation
    cannot run fails now, with the caller's error handling, not later on the page."""
    from actorswarm.web.sim_source import SimSource

    run.schedule(events, faults)
    run.advance(0.0)
    sha = hashlib.sha256(file.read_bytes()).hexdigest()
    source = SimSource(run, title=f"simulation of {file.name}", sha=sha, speed=speed)
    _serve(source, host, port, token)


def serve_mission(
    mission: Mission,
    *,
    platforms: int | None = None,
    seed: int = 0,
    loss: float = 0.0,
    kills: tuple[tuple[int, float], ...] = (),
    host: str = DEFAULT_HOST,
    port: int = DEFAULT_PORT,
    token: str | None = None,
    speed: float = 1.0,
) -> None:
    """``actorswarm demo --serve``: the shipped mission, served until stopped."""
    from actorswarm.sim.mission import prepare
    from actorswarm.web.sim_source import SimSource

    run = prepare(mission, platforms=platforms, seed=seed, loss=loss, kills=kills)
    run.advance(0.0)
    sha = hashlib.sha256(mission.script_path.read_bytes()).hexdigest()
    n = platforms or mission.platforms
    title = (
        f"{mission.title}" if n == mission.platforms else f"{mission.name} mission, {n} platforms"
    )
    _serve(SimSource(run, title=title, sha=sha, speed=speed), host, port, token)


def _known_script(script: Path | None, state: Path) -> tuple[TaskScript | None, str]:
    """The script to draw: ``--script`` (refused with its diagnostics when invalid), or the
    one ``gs deploy`` remembered in ``state`` (quietly nothing when it cannot be read)."""
    import json

    from actorswarm.dsl import check_file

    path = script
    if path is None:
        try:
            path = Path(json.loads(state.read_text())["file"])
        except (OSError, ValueError, KeyError, TypeError):
            return None, ""
    try:
        result = check_file(path)
        data = path.read_bytes()
    except OSError as exc:
        if script is None:
            return None, ""
        typer.echo(f"{path}: cannot read the file: {exc.strerror or exc}", err=True)
        raise typer.Exit(2) from None
    if result.script is None or not result.ok:
        if script is None:
            return None, ""
        for d in result.diagnostics:
            typer.echo(str(d), err=True)
        raise typer.Exit(1)
    return result.script, hashlib.sha256(data).hexdigest()


def _attached_script(text: object) -> tuple[TaskScript | None, str]:
    """The task script a recording carries (an MCAP attachment), when it checks cleanly:
    the state machine to draw without ``--script``."""
    if not isinstance(text, str):
        return None, ""
    from actorswarm.dsl import check

    result = check(text, path="<the recording's script>")
    if result.script is None or not result.ok:
        return None, ""
    return result.script, hashlib.sha256(text.encode()).hexdigest()


@link_options
def gs_web(
    conn: LinkOptions,
    script: Annotated[
        Path | None,
        typer.Option(help="The script the swarm runs, to draw (default: the last gs deploy's)."),
    ] = None,
    state: Annotated[Path | None, typer.Option(help="Where gs deploy remembered it.")] = None,
    poll: Annotated[
        float, typer.Option(min=0.2, help="Seconds between two status requests.")
    ] = 1.0,
    host: HostOpt = DEFAULT_HOST,
    port: PortOpt = DEFAULT_PORT,
    token: TokenOpt = None,
    world: Annotated[
        Path | None,
        typer.Option(
            help="The world (TOML) the swarm flies in: its areas are drawn, and a script "
            "deployed from the page must name only those."
        ),
    ] = None,
) -> None:
    """The web ground station for a real swarm: a live view and the operator's controls
    in the browser. Open the address it prints."""
    from actorswarm.cli.common import read_world

    ln = conn.link()
    known_world = None if world is None else read_world(world)
    drawn, sha = _known_script(script, state or default_state_file(ln.swarm))
    from actorswarm.web.real_source import RealSource

    source = RealSource(ln.session(), script=drawn, sha=sha, poll=poll, world=known_world)
    _serve(source, host, port, token)


def web(
    replay: Annotated[
        Path,
        typer.Option(
            help="Play this recording back (MCAP or JSON Lines, of sim, demo or gs record)."
        ),
    ],
    script: Annotated[
        Path | None, typer.Option(help="The task script the run ran, to draw its state machine.")
    ] = None,
    speed: Annotated[
        float, typer.Option(min=0.1, max=100.0, help="Recording seconds per wall second.")
    ] = 1.0,
    paused: Annotated[bool, typer.Option("--paused", help="Start paused at time 0.")] = False,
    host: HostOpt = DEFAULT_HOST,
    port: PortOpt = DEFAULT_PORT,
    token: TokenOpt = None,
) -> None:
    """The web ground station on a recording: the run played back on the map, the timeline
    and the swarm table, with pause, pace and seek. Open the address it prints."""
    from actorswarm.recording import read_recording
    from actorswarm.sim.record import RecordError

    try:
        recording = read_recording(replay)
    except (RecordError, OSError) as exc:
        text = str(exc)
        typer.echo(text if str(replay) in text else f"{replay}: {text}", err=True)
        raise typer.Exit(2) from None
    for note in recording.notes:
        typer.echo(f"{replay}: {note}", err=True)
    drawn, sha = (None, "") if script is None else _known_script(script, Path())
    if drawn is None:
        drawn, sha = _attached_script(recording.meta.get("script_text"))
    from actorswarm.web.replay_source import ReplaySource

    source = ReplaySource(
        recording,
        title=f"replay of {replay.name}",
        script=drawn,
        sha=sha,
        speed=speed,
        playing=not paused,
    )
    _serve(source, host, port, token)


def register(gs_app: typer.Typer) -> None:
    """Add ``web`` to the ``gs`` command group."""
    gs_app.command("web")(gs_web)
