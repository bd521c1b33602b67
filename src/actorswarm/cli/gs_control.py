"""The operator's interventions over a real swarm: ``gs event``, ``force``, ``pause``,
``activate``, ``stop`` and ``backup``.

Each sends one command to the platforms listed with ``--platforms`` (default: every
platform heard within 1.5 s), waits for every one of them to answer, and prints one line
per platform: what it did, why it refused, or that it did not answer. The exit status is
0 when every platform answered and at least one carried the command out, 1 otherwise, 2
for unusable options.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Annotated

import typer

from actorswarm.cli.common import id_list, run_async
from actorswarm.cli.swarm_options import Link, LinkOptions, TimeoutOpt, link_options
from actorswarm.engine import commands as cmds
from actorswarm.ground.station import GroundStation
from actorswarm.suggest import did_you_mean

__all__ = ["register"]

PlatformsOpt = Annotated[
    str | None, typer.Option(help="Only these platforms: IDS (1-4,7); default every one heard.")
]
ActorArg = Annotated[str, typer.Argument(help="The actor.")]

#: Sends the command to the given platforms.
Send = Callable[[GroundStation, list[int], float], None]


async def _run(
    ln: Link, name: str, send: Send, platforms: list[int] | None, timeout: float
) -> tuple[list[int], dict[int, tuple[bool, str]], set[int], list[str]]:
    """The targets, the answers per platform, the platforms the command was given up on
    (never acknowledged within ``timeout``), and why the silent ones said nothing."""
    async with ln.session(timeout) as gs:
        if platforms is None:
            await gs.listen(1.5)  # heartbeats say who is there
        targets = sorted(gs.station.heard) if platforms is None else platforms
        if targets:
            gs.do(lambda st, now: send(st, targets, now))

        def answers() -> dict[int, tuple[bool, str]]:
            return gs.station.outcomes(name)

        if targets:
            await gs.wait_for(lambda: set(targets) <= set(answers()), timeout)
        got = answers()
        why = gs.explain(targets, got)
        return targets, got, set(gs.station.unreachable) - set(got), why


def _execute(
    ln: Link,
    name: str,
    send: Send,
    platforms: str | None,
    timeout: float,
    actor: str | None = None,
) -> None:
    """Send, wait, print the outcome per platform and why the silent ones said nothing,
    exit with the status of the module docstring. When every platform refused for the
    same reason, that reason is one line for all of them, with a suggestion for ``actor``
    (the command's ACTOR) when the platforms named the actors they have."""
    chosen = None if platforms is None else id_list(platforms, "--platforms")
    targets, answers, unreachable, why = run_async(_run(ln, name, send, chosen, timeout))
    same = _one_refusal(targets, answers)
    if same is not None:
        hint = ""
        if actor is not None:
            have = sorted({a for m in re.findall(r"\(loaded: ([^)]*)\)", same) for a in
                           m.split(", ") if a and a != "none"})  # fmt: skip
            hint = did_you_mean(actor, have)
        typer.echo(f"  {_ids(targets)}: FAILED: {same}{hint}")
    for p in targets if same is None else ():
        silent = "no answer"
        if p in unreachable:
            silent = f"unreachable: nothing acknowledged in {timeout:g} s"
        ok, message = answers.get(p, (False, silent))
        typer.echo(f"  {p}: {message}" if ok else f"  {p}: FAILED: {message}")
    for line in why:
        typer.echo(line, err=True)
    if not targets or set(targets) - set(answers) or not any(ok for ok, _ in answers.values()):
        raise typer.Exit(1)


def _one_refusal(targets: list[int], answers: dict[int, tuple[bool, str]]) -> str | None:
    """The reason, when more than one platform was asked and every one refused for the
    same reason (its own number taken out); None otherwise."""
    if len(targets) < 2 or set(targets) - set(answers):
        return None
    reasons = {
        re.sub(r" on platform \d+", "", message) for ok, message in answers.values() if not ok
    }
    if len(reasons) != 1 or any(ok for ok, _ in answers.values()):
        return None
    return reasons.pop()


def _ids(platforms: list[int]) -> str:
    """``1-4,7``: the platforms as ranges."""
    parts: list[str] = []
    for p in sorted(platforms):
        if parts and parts[-1].split("-")[-1] == str(p - 1):
            parts[-1] = f"{parts[-1].split('-')[0]}-{p}"
        else:
            parts.append(str(p))
    return ",".join(parts)


def _to(command: cmds.Command) -> Send:
    return lambda st, targets, now: st.send(command, targets, now)


@link_options
def gs_event(
    name: Annotated[str, typer.Argument(help="The event to fire.")],
    conn: LinkOptions,
    timeout: TimeoutOpt = 5.0,
    platforms: PlatformsOpt = None,
    actors: Annotated[str | None, typer.Option(help="Only platforms running these actors.")] = None,
) -> None:
    """Fire an event: every platform heard (or the ones listed) gets it."""
    ln = conn.link()
    names = [a.strip() for a in (actors or "").split(",") if a.strip()]

    def send(st: GroundStation, targets: list[int], now: float) -> None:
        st.event(name, now, platforms=targets, actors=names)

    _execute(ln, "Inject", send, platforms, timeout)


def _params(values: list[str] | None) -> dict[str, str]:
    out: dict[str, str] = {}
    for value in values or ():
        key, eq, text = value.partition("=")
        if not eq or not key.strip():
            typer.echo(f"--param {value!r}: write KEY=VALUE", err=True)
            raise typer.Exit(2)
        out[key.strip()] = text
    return out


@link_options
def gs_force(
    actor: Annotated[
        str | None, typer.Argument(help="The actor to move away from (default: any running).")
    ] = None,
    to: Annotated[str, typer.Option("--to", help="The actor to switch to.")] = "",
    param: Annotated[
        list[str] | None,
        typer.Option(metavar="KEY=VALUE", help="A param of the new actor (repeatable)."),
    ] = None,
    *,
    conn: LinkOptions,
    timeout: TimeoutOpt = 5.0,
    platforms: PlatformsOpt = None,
) -> None:
    """Forced transition to --to, now and without a barrier.

    Who moves: the platforms running ACTOR, or the --platforms listed (whatever they run),
    or the listed ones that run ACTOR when both are given."""
    if not to:
        typer.echo("say where to: --to ACTOR", err=True)
        raise typer.Exit(2)
    if actor is None and platforms is None:
        typer.echo("say who moves: an ACTOR to move away from, or --platforms IDS", err=True)
        raise typer.Exit(2)
    command = cmds.Force(to=to, src=actor, params=_params(param))
    ln = conn.link()
    _execute(ln, "Force", _to(command), platforms, timeout)


def _actor_command(name: str, make: Callable[[str], cmds.Command], doc: str) -> Callable[..., None]:
    @link_options
    def command(
        actor: ActorArg,
        conn: LinkOptions,
        timeout: TimeoutOpt = 5.0,
        platforms: PlatformsOpt = None,
    ) -> None:
        ln = conn.link()
        _execute(ln, name, _to(make(actor)), platforms, timeout, actor)

    command.__doc__ = doc
    return command


@link_options
def gs_backup(
    conn: LinkOptions,
    timeout: TimeoutOpt = 5.0,
    platforms: PlatformsOpt = None,
) -> None:
    """Every platform saves its actors and their plugins' state now.

    A restarted daemon resumes from its latest backup."""
    ln = conn.link()
    _execute(ln, "Backup", _to(cmds.Backup()), platforms, timeout)


def register(app: typer.Typer) -> None:
    """Add the commands of this module to the ``gs`` command group."""
    app.command("event")(gs_event)
    app.command("force")(gs_force)
    app.command("pause")(
        _actor_command(
            "Pause",
            lambda a: cmds.Pause(actor=a),
            "Pause ACTOR where it runs: its steps stop and its hardware is given back; its "
            "state is kept until `gs activate`.",
        )
    )
    app.command("activate")(
        _actor_command(
            "Activate", lambda a: cmds.Activate(actor=a), "Resume ACTOR where it was paused."
        )
    )
    app.command("stop")(
        _actor_command(
            "ForceStop",
            lambda a: cmds.ForceStop(actor=a),
            "Stop ACTOR where it runs (forced; the platform is left without it).",
        )
    )
    app.command("backup")(gs_backup)
