"""``actorswarm daemon`` and ``actorswarm gs ...``: a real swarm over Zenoh.

``daemon`` runs one platform (:mod:`actorswarm.daemon.run`). The ``gs`` commands each open
a ground-station session (:class:`~actorswarm.daemon.ground.GroundSession`), act, wait for
the swarm's answers and print them: ``deploy`` a script and wait for every expected
platform to confirm its SHA-256, ``start`` it, inject an ``event``, read the swarm's
``status``. ``deploy`` remembers what it deployed (in ``--state``, by default under the
user's state directory) so a later ``start`` knows which script to start.
"""

from __future__ import annotations

import asyncio
import json
import os
from pathlib import Path
from typing import Annotated, Any, Literal

import typer

from actorswarm.cli.common import int_list_or_count
from actorswarm.security.guard import PacketGuard
from actorswarm.transport.zenoh_transport import ZenohSettings, key_prefix

gs_app = typer.Typer(
    help="The ground station over a real swarm: deploy, start, event, status.",
    no_args_is_help=True,
)

SwarmOpt = Annotated[str, typer.Option(help="The swarm's name (its Zenoh namespace).")]
ConnectOpt = Annotated[
    list[str] | None, typer.Option(help="Zenoh endpoint to connect to (repeatable).")
]
ListenOpt = Annotated[list[str] | None, typer.Option(help="Zenoh endpoint to listen on.")]
MulticastOpt = Annotated[
    bool, typer.Option("--multicast/--no-multicast", help="Multicast scouting of peers.")
]
TimeoutOpt = Annotated[float, typer.Option(min=0.1, help="Seconds to wait for the swarm.")]
KeysOpt = Annotated[
    Path | None,
    typer.Option(help="The swarm's key directory (default: the user's; see `keys init`)."),
]
InsecureOpt = Annotated[
    bool, typer.Option("--insecure", help="No packet authentication (trusted networks only).")
]


def _guard(keys: Path | None, insecure: bool, role: Literal["platform", "ground"]) -> PacketGuard:
    """The packet guard for ``role``, or a clear error and exit 2 when the keys are not
    usable."""
    from actorswarm.security import KeyFileError, default_key_dir, load_keys

    if insecure:
        typer.echo("WARNING: --insecure: packets are not authenticated", err=True)
        return PacketGuard.insecure()
    directory = keys or default_key_dir()
    try:
        loaded = load_keys(directory, need_private=role == "ground")
    except KeyFileError as exc:
        typer.echo(
            f"{exc}\ncreate keys with `actorswarm keys init --dir {directory}` and copy "
            "swarm.key and ground_station.pub to every platform, or run with --insecure",
            err=True,
        )
        raise typer.Exit(2) from None
    return PacketGuard.from_keys(loaded, role=role)


def _settings(
    connect: list[str] | None, listen: list[str] | None, multicast: bool
) -> ZenohSettings:
    return ZenohSettings(
        listen=tuple(listen or ()), connect=tuple(connect or ()), multicast=multicast
    )


def _check_swarm(swarm: str) -> None:
    try:
        key_prefix(swarm)
    except ValueError as exc:
        typer.echo(str(exc), err=True)
        raise typer.Exit(2) from None


def default_state_file(swarm: str) -> Path:
    base = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(base) / "actorswarm" / f"gs-{swarm}.json"


def daemon(
    platform: Annotated[int, typer.Option(min=1, max=65535, help="This platform's ID.")],
    swarm: SwarmOpt = "swarm",
    listen: ListenOpt = None,
    connect: ConnectOpt = None,
    multicast: MulticastOpt = True,
    state_dir: Annotated[
        Path | None, typer.Option(help="Where the platform keeps its state (default: ./state-ID).")
    ] = None,
    keys: KeysOpt = None,
    insecure: InsecureOpt = False,
) -> None:
    """Run one platform of a real swarm over Zenoh until SIGTERM/SIGINT."""
    from actorswarm.daemon.run import DaemonOptions, run_daemon

    _check_swarm(swarm)
    guard = _guard(keys, insecure, "platform")
    options = DaemonOptions(
        guard=guard,
        platform=platform,
        swarm=swarm,
        state_dir=state_dir or Path(f"state-{platform}"),
        zenoh=_settings(connect, listen, multicast),
    )
    raise typer.Exit(run_daemon(options))


@gs_app.command("deploy")
def gs_deploy(
    file: Annotated[Path, typer.Argument(help="The task script to deploy.")],
    expect: Annotated[str, typer.Option(help="Platforms that must confirm: IDS (1-10,12) or N.")],
    swarm: SwarmOpt = "swarm",
    connect: ConnectOpt = None,
    listen: ListenOpt = None,
    multicast: MulticastOpt = True,
    timeout: TimeoutOpt = 10.0,
    state: Annotated[Path | None, typer.Option(help="Where to remember the deployment.")] = None,
    keys: KeysOpt = None,
    insecure: InsecureOpt = False,
) -> None:
    """Send a script to the swarm and wait until every expected platform confirmed it."""
    from actorswarm.daemon.ground import GroundSession
    from actorswarm.dsl import check_file

    _check_swarm(swarm)
    guard = _guard(keys, insecure, "ground")
    platforms = int_list_or_count(expect, "--expect")
    result = check_file(file)
    if result.script is None or not result.ok:
        for d in result.diagnostics:
            typer.echo(str(d), err=True)
        raise typer.Exit(1)
    data = file.read_bytes()

    async def go() -> tuple[str, list[int]]:
        async with GroundSession(swarm, _settings(connect, listen, multicast), guard) as gs:
            sha = gs.do(lambda st, now: st.deploy(data, platforms, now))
            await gs.wait_for(lambda: not gs.station.missing(sha), timeout)
            return sha, gs.station.missing(sha)

    sha, missing = asyncio.run(go())
    confirmed = sorted(set(platforms) - set(missing))
    path = state or default_state_file(swarm)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"sha256": sha, "file": str(file.resolve()), "expect": platforms}))
    typer.echo(f"script {sha[:12]}: confirmed by {len(confirmed)} of {len(platforms)}: {confirmed}")
    if missing:
        typer.echo(f"not confirmed by: {missing}", err=True)
        raise typer.Exit(1)


@gs_app.command("start")
def gs_start(
    swarm: SwarmOpt = "swarm",
    connect: ConnectOpt = None,
    listen: ListenOpt = None,
    multicast: MulticastOpt = True,
    timeout: TimeoutOpt = 10.0,
    force: Annotated[
        bool, typer.Option("--force", help="Start without every confirmation.")
    ] = False,
    state: Annotated[Path | None, typer.Option(help="Where deploy remembered the script.")] = None,
    keys: KeysOpt = None,
    insecure: InsecureOpt = False,
) -> None:
    """Start the script deployed last: refused unless every expected platform confirmed it."""
    from actorswarm.daemon.ground import GroundSession
    from actorswarm.engine import commands as cmds
    from actorswarm.ground.station import NotConfirmed

    _check_swarm(swarm)
    guard = _guard(keys, insecure, "ground")
    path = state or default_state_file(swarm)
    try:
        saved: dict[str, Any] = json.loads(path.read_text())
        data = Path(saved["file"]).read_bytes()
        platforms = [int(p) for p in saved["expect"]]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        typer.echo(f"{path}: nothing deployed to start ({exc}); run gs deploy first", err=True)
        raise typer.Exit(2) from None

    async def go() -> tuple[list[int], list[int], str]:
        async with GroundSession(swarm, _settings(connect, listen, multicast), guard) as gs:
            # Deploying again is idempotent (a platform that has the script confirms at
            # once): it tells this session who has it.
            sha = gs.do(lambda st, now: st.deploy(data, platforms, now))
            await gs.wait_for(lambda: not gs.station.missing(sha), min(timeout, 5.0))
            try:
                gs.do(lambda st, now: st.start(now, force=force))
            except NotConfirmed as exc:
                return [], exc.missing, str(exc)

            def started() -> set[int]:
                return {
                    r.platform
                    for r in gs.station.replies
                    if isinstance(r.reply, cmds.Result) and r.reply.command == "Start"
                }

            await gs.wait_for(lambda: set(platforms) <= started(), timeout)
            return sorted(started()), gs.station.missing(sha), ""

    started, missing, refused = asyncio.run(go())
    if refused:
        typer.echo(refused, err=True)
        raise typer.Exit(1)
    typer.echo(f"started on {len(started)} of {len(platforms)}: {started}")
    if missing:
        typer.echo(f"never confirmed the script: {missing}", err=True)
    if set(platforms) - set(started):
        raise typer.Exit(1)


@gs_app.command("event")
def gs_event(
    name: Annotated[str, typer.Argument(help="The event to fire.")],
    swarm: SwarmOpt = "swarm",
    connect: ConnectOpt = None,
    listen: ListenOpt = None,
    multicast: MulticastOpt = True,
    timeout: TimeoutOpt = 5.0,
    platforms: Annotated[str | None, typer.Option(help="Only these platforms: IDS.")] = None,
    actors: Annotated[str | None, typer.Option(help="Only platforms running these actors.")] = None,
    keys: KeysOpt = None,
    insecure: InsecureOpt = False,
) -> None:
    """Fire an event: every platform heard (or the ones listed) gets it."""
    from actorswarm.daemon.ground import GroundSession
    from actorswarm.engine import commands as cmds

    _check_swarm(swarm)
    guard = _guard(keys, insecure, "ground")
    targets = None if platforms is None else int_list_or_count(platforms, "--platforms")
    names = [a.strip() for a in (actors or "").split(",") if a.strip()]

    async def go() -> tuple[list[int], dict[int, str]]:
        async with GroundSession(swarm, _settings(connect, listen, multicast), guard) as gs:
            if targets is None:
                await gs.listen(1.5)  # heartbeats say who is there
            to = sorted(gs.station.heard) if targets is None else targets
            gs.do(lambda st, now: st.event(name, now, platforms=to, actors=names))

            def answers() -> dict[int, str]:
                return {
                    r.platform: r.reply.message
                    for r in gs.station.replies
                    if isinstance(r.reply, cmds.Result) and r.reply.command == "Inject"
                }

            await gs.wait_for(lambda: set(to) <= set(answers()), timeout)
            return to, answers()

    to, answers = asyncio.run(go())
    for p in to:
        typer.echo(f"  {p}: {answers.get(p, 'no answer')}")
    if not to:
        typer.echo("no platform heard", err=True)
        raise typer.Exit(1)
    if set(to) - set(answers):
        raise typer.Exit(1)


@gs_app.command("status")
def gs_status(
    swarm: SwarmOpt = "swarm",
    connect: ConnectOpt = None,
    listen: ListenOpt = None,
    multicast: MulticastOpt = True,
    timeout: TimeoutOpt = 3.0,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
    keys: KeysOpt = None,
    insecure: InsecureOpt = False,
) -> None:
    """Each platform heard: its actors, master flag, epoch, incarnation, last heard."""
    from actorswarm.daemon.ground import GroundSession
    from actorswarm.daemon.loop import clock
    from actorswarm.engine import commands as cmds

    _check_swarm(swarm)
    guard = _guard(keys, insecure, "ground")

    async def go() -> dict[str, Any]:
        async with GroundSession(swarm, _settings(connect, listen, multicast), guard) as gs:
            await gs.listen(1.5)
            heard = sorted(gs.station.heard)
            gs.do(lambda st, now: st.send(cmds.Status(), heard, now))

            def replies() -> dict[int, cmds.StatusReply]:
                return {
                    r.platform: r.reply
                    for r in gs.station.replies
                    if isinstance(r.reply, cmds.StatusReply)
                }

            await gs.wait_for(lambda: set(heard) <= set(replies()), timeout)
            now = clock()
            out: dict[str, Any] = {}
            got = replies()
            for p in heard:
                incarnation, master, epoch = gs.station.state[p]
                reply = got.get(p)
                out[str(p)] = {
                    "actors": []
                    if reply is None
                    else [a for a, s in reply.actors.items() if s == "running"],
                    "master": master,
                    "epoch": epoch,
                    "incarnation": incarnation,
                    "last_heard_s": round(now - gs.station.heard[p], 3),
                    "script": "" if reply is None else reply.script,
                }
            return {"platforms": out}

    status = asyncio.run(go())
    if as_json:
        typer.echo(json.dumps(status, indent=2))
        return
    if not status["platforms"]:
        typer.echo("no platform heard", err=True)
        raise typer.Exit(1)
    for p, row in status["platforms"].items():
        flag = " (master)" if row["master"] else ""
        typer.echo(
            f"  {p}{flag}: {', '.join(row['actors']) or '-'}; epoch {row['epoch']}, "
            f"incarnation {row['incarnation']}, heard {row['last_heard_s']} s ago"
        )
