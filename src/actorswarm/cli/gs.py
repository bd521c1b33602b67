"""``actorswarm gs ...``: the ground station over a real swarm (Zenoh).

Each command opens a ground-station session
(:class:`~actorswarm.daemon.ground.GroundSession`), acts, waits for the swarm's answers
and prints them: ``deploy`` a script and wait for every expected platform to confirm its
SHA-256, ``start`` it, read the swarm's ``status``. ``deploy`` remembers what it deployed
(in ``--state``, by default under the user's state directory) so a later ``start`` knows
which script to start. The operator's interventions (``event``, ``force``, ``pause``...)
are in :mod:`actorswarm.cli.gs_control`.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Annotated, Any

import typer

from actorswarm.cli.common import (
    check_script,
    int_list_or_count,
    output_file,
    read_world,
    run_async,
)
from actorswarm.cli.swarm_options import (
    LinkOptions,
    TimeoutOpt,
    default_state_file,
    link_options,
)

#: Where ``deploy`` remembers and ``start`` finds the script, as the help says it.
_STATE_DEFAULT = "$XDG_STATE_HOME/actorswarm/gs-SWARM.json, or ~/.local/state/actorswarm/..."

gs_app = typer.Typer(
    help="The ground station over a real swarm: deploy, start, event, force, pause, "
    "activate, stop, backup, status; record it, or watch it on the web page.",
    no_args_is_help=True,
)


@gs_app.callback()
def _connection(
    ctx: typer.Context,
    profile: Annotated[
        Path | None,
        typer.Option(
            envvar="ACTORSWARM_PROFILE",
            help="A profile file (TOML) with the connection settings (swarm, connect, "
            "multicast, keys or insecure...), as `actorswarm launch` writes one; the command "
            "line and the ACTORSWARM_* environment variables come first.",
        ),
    ] = None,
) -> None:
    """The ground station over a real swarm. Connection settings come from each
    command's options, the ACTORSWARM_* environment variables, then --profile."""
    from actorswarm.cli.profile import ProfileError, apply_profile

    try:
        # Before the command reads its options (and so their environment variables).
        ctx.call_on_close(apply_profile(profile))
    except ProfileError as exc:
        typer.echo(str(exc), err=True)
        raise typer.Exit(2) from None


@gs_app.command("deploy")
@link_options
def gs_deploy(
    file: Annotated[Path, typer.Argument(help="The task script to deploy.")],
    expect: Annotated[str, typer.Option(help="Platforms that must confirm: IDS (1-10,12) or N.")],
    conn: LinkOptions,
    timeout: TimeoutOpt = 10.0,
    state: Annotated[
        Path | None,
        typer.Option(help="Where to remember the deployment.", show_default=_STATE_DEFAULT),
    ] = None,
    world: Annotated[
        Path | None,
        typer.Option(
            help="The world (TOML) the swarm flies in: refuse a script naming an area it "
            "does not have, before anything is sent, and warn about separation and the ceiling."
        ),
    ] = None,
) -> None:
    """Send a script to the swarm and wait until every expected platform confirmed it.

    The script is checked first, as task check does (with --world, its area names too, and
    the safety warnings of docs/safety.md, which do not stop the deployment):
    a script with errors is not sent, its diagnostics go to stderr as FILE:LINE:COL:
    message, and the exit status is 1 (2 when the script or the world cannot be read)."""
    ln = conn.link()
    platforms = int_list_or_count(expect, "--expect")
    output_file(state or default_state_file(ln.swarm), "--state")  # before anything is sent
    world_config = None if world is None else read_world(world)
    areas = None if world_config is None else [area.name for area in world_config.areas]
    code, script = check_script(file, areas=areas, world=world_config)
    if script is None or code:
        raise typer.Exit(code or 1)
    try:
        data = file.read_bytes()
    except OSError as exc:  # removed or made unreadable since it was checked
        typer.echo(f"{file}: cannot read the file: {exc.strerror or exc}", err=True)
        raise typer.Exit(2) from None

    async def go() -> tuple[str, list[int], list[int], list[str]]:
        async with ln.session(timeout) as gs:
            sha = gs.do(lambda st, now: st.deploy(data, platforms, now))
            await gs.wait_for(lambda: not gs.station.missing(sha), timeout)
            missing = gs.station.missing(sha)
            why = gs.explain(platforms, set(platforms) - set(missing))
            return sha, missing, sorted(set(missing) & set(gs.station.unreachable)), why

    sha, missing, unreachable, why = run_async(go())
    confirmed = sorted(set(platforms) - set(missing))
    path = state or default_state_file(ln.swarm)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"sha256": sha, "file": str(file.resolve()), "expect": platforms}))
    typer.echo(f"script {sha[:12]}: confirmed by {len(confirmed)} of {len(platforms)}: {confirmed}")
    if missing:
        typer.echo(f"not confirmed by: {missing}", err=True)
        if unreachable:
            typer.echo(f"never acknowledged a chunk (unreachable?): {unreachable}", err=True)
        for line in why:
            typer.echo(line, err=True)
        raise typer.Exit(1)


@gs_app.command("start")
@link_options
def gs_start(
    conn: LinkOptions,
    timeout: TimeoutOpt = 10.0,
    force: Annotated[
        bool, typer.Option("--force", help="Start without every confirmation.")
    ] = False,
    state: Annotated[
        Path | None,
        typer.Option(help="Where deploy remembered the script.", show_default=_STATE_DEFAULT),
    ] = None,
) -> None:
    """Start the script deployed last: refused unless every expected platform confirmed it."""
    from actorswarm.ground.station import NotConfirmed

    ln = conn.link()
    path = state or default_state_file(ln.swarm)
    try:
        saved: dict[str, Any] = json.loads(path.read_text())
        data = Path(saved["file"]).read_bytes()
        platforms = [int(p) for p in saved["expect"]]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        typer.echo(f"{path}: nothing deployed to start ({exc}); run gs deploy first", err=True)
        raise typer.Exit(2) from None

    async def go() -> tuple[list[int], list[int], str, list[str], float | None]:
        async with ln.session(timeout) as gs:
            # Deploying again is idempotent (a platform that has the script confirms at
            # once): it tells this session who has it.
            sha = gs.do(lambda st, now: st.deploy(data, platforms, now))
            await gs.wait_for(lambda: not gs.station.missing(sha), timeout)
            try:
                # The task's clock: now on this machine's (UTC), unless the platforms
                # that run the script already began it (then theirs).
                began = gs.do(lambda st, now: st.start(now, force=force, began=time.time()))
            except NotConfirmed as exc:
                confirmed = set(platforms) - set(exc.missing)
                return [], exc.missing, str(exc), gs.explain(platforms, confirmed), None

            def answered() -> dict[int, tuple[bool, str]]:
                return gs.station.outcomes("Start")

            await gs.wait_for(lambda: set(platforms) <= set(answered()), timeout)
            for p, (ok, message) in sorted(answered().items()):
                if not ok:
                    typer.echo(f"  {p}: FAILED: {message}", err=True)
            started = [p for p, (ok, _) in answered().items() if ok]
            why = gs.explain(platforms, answered())
            return sorted(started), gs.station.missing(sha), "", why, began

    started, missing, refused, why, began = run_async(go())
    if refused:
        typer.echo(refused, err=True)
        for line in why:
            typer.echo(line, err=True)
        raise typer.Exit(1)
    typer.echo(f"started on {len(started)} of {len(platforms)}: {started}")
    if began is not None:
        typer.echo(f"the task's clock began at {utc_text(began)}")
    if missing:
        typer.echo(f"never confirmed the script: {missing}", err=True)
    for line in why:
        typer.echo(line, err=True)
    if set(platforms) - set(started):
        raise typer.Exit(1)


def utc_text(t: float) -> str:
    """UTC seconds as ``2026-12-07T23:59:01.250Z``."""
    ms = round(t * 1000)
    whole = time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(ms // 1000))
    return f"{whole}.{ms % 1000:03d}Z"


#: How far a platform's clock may be from the ground station's before ``gs status`` warns:
#: a formation's leader 0.25 s off is 4.5 m at 18 m/s.
CLOCK_TOLERANCE_S = 0.25


def _clock_offset(theirs: float, asked: float, answered: float) -> float:
    """A platform's clock minus this machine's (UTC seconds), taking its reading to fall
    midway between the request (``asked``) and its answer (``answered``): off by at most
    half the round trip."""
    return round(theirs - (asked + answered) / 2.0, 3)


def _clock_lines(rows: dict[str, dict[str, Any]]) -> list[str]:
    """What ``gs status`` says of the task's clock: when the task began, and a warning for
    platforms that disagree on it or whose clock is off this machine's."""
    began = {p: row["began"] for p, row in rows.items() if row.get("began") is not None}
    lines = []
    instants = sorted(set(began.values()))
    if len(instants) == 1:
        when = utc_text(instants[0])
        lines.append(f"the task's clock began at {when} on {len(began)} platform(s)")
    elif instants:
        said = "; ".join(
            f"{utc_text(t)}: {', '.join(p for p, b in began.items() if b == t)}" for t in instants
        )
        lines.append(f"warning: the platforms run tasks begun at different instants ({said})")
    for p, row in rows.items():
        offset = row.get("clock_offset_s")
        spread = row.get("clock_uncertainty_s") or 0.0
        # Only a clock surely off: beyond the tolerance by more than the reading's doubt.
        if offset is not None and abs(offset) - spread > CLOCK_TOLERANCE_S:
            side = "ahead of" if offset > 0 else "behind"
            lines.append(
                f"warning: platform {p}'s clock is {abs(offset):.2f} s {side} this machine's: "
                "what the swarm does on the task's clock (a formation's depart) needs their "
                "clocks to agree (GPS or NTP)"
            )
    return lines


def _status_line(platform: str, row: dict[str, Any]) -> str:
    """One platform's line of ``gs status`` (``row``: its entry of ``--json``)."""
    flag = " (master)" if row["master"] else ""
    said = (", ".join(row["actors"]) or "-") if row["answered"] else "no answer"
    if row["roles"]:
        said += f" (roles {', '.join(row['roles'])})"
    return (
        f"  {platform}{flag}: {said}; epoch {row['epoch']}, "
        f"incarnation {row['incarnation']}, heard {row['last_heard_s']} s ago"
        + _vehicle_line(row["vehicle"])
    )


def _vehicle_line(vehicle: dict[str, Any]) -> str:
    """``; vehicle: link up, ardupilot GUIDED, armed, battery 87 %`` (empty without one)."""
    from actorswarm.ground.vehicle import describe

    said = describe(vehicle)
    return f"; vehicle: {said}" if said else ""


@gs_app.command("status")
@link_options
def gs_status(
    conn: LinkOptions,
    timeout: TimeoutOpt = 3.0,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """Each platform heard: its actors, roles, master flag, epoch, incarnation, last heard.

    Exits 1 when no platform answered (none heard, or every one refused the request), and
    says why as far as the ground station can tell."""
    from actorswarm.daemon.loop import clock
    from actorswarm.engine import commands as cmds

    ln = conn.link()

    async def go() -> tuple[dict[str, Any], list[str]]:
        async with ln.session(timeout) as gs:
            await gs.listen(1.5)
            heard = sorted(gs.station.heard)
            asked = clock()
            if heard:
                gs.do(lambda st, now: st.send(cmds.Status(), heard, now))

            def replies() -> dict[int, cmds.StatusReply]:
                return {p: r.reply for p, r in records().items()}

            def records() -> dict[int, Any]:
                return {
                    r.platform: r
                    for r in gs.station.replies
                    if isinstance(r.reply, cmds.StatusReply)
                }

            if heard:
                await gs.wait_for(lambda: set(heard) <= set(replies()), timeout)
            now = clock()
            utc = time.time() - now  # this machine's UTC minus the session's clock
            out: dict[str, Any] = {}
            got = replies()
            answered_at = {p: r.t for p, r in records().items()}
            for p in heard:
                incarnation, master, epoch = gs.station.state[p]
                reply = got.get(p)
                offset = spread = None
                if reply is not None and reply.clock is not None:
                    offset = _clock_offset(reply.clock, asked + utc, answered_at[p] + utc)
                    spread = round((answered_at[p] - asked) / 2.0, 3)
                out[str(p)] = {
                    # False: heard, but its answer never came (see the reasons printed).
                    "answered": reply is not None,
                    "actors": []
                    if reply is None
                    else [a for a, s in reply.actors.items() if s == "running"],
                    "master": master,
                    "epoch": epoch,
                    "incarnation": incarnation,
                    "last_heard_s": round(now - gs.station.heard[p], 3),
                    "script": "" if reply is None else reply.script,
                    "vehicle": {} if reply is None else dict(reply.vehicle),
                    "roles": [] if reply is None else list(reply.roles),
                    # When its task began (UTC seconds), and how far its clock is from this
                    # machine's (seconds, ± clock_uncertainty_s, half the answer's round
                    # trip; None: not said).
                    "began": None if reply is None else reply.began,
                    "clock_offset_s": offset,
                    "clock_uncertainty_s": spread,
                }
            return {"platforms": out}, gs.explain(heard, got)

    status, why = run_async(go())
    rows = status["platforms"]
    if as_json:
        typer.echo(json.dumps(status, indent=2))
    for p, row in rows.items() if not as_json else ():
        typer.echo(_status_line(p, row))
    if not as_json:
        for line in _clock_lines(rows):
            typer.echo(line, err=line.startswith("warning"))
    for line in why:
        typer.echo(line, err=True)
    if not any(row["answered"] for row in rows.values()):
        raise typer.Exit(1)
