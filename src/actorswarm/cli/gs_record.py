"""``actorswarm gs record OUT.mcap``: record a real swarm as ``sim --record`` records a
simulation.

A ground-station session (the same one the other ``gs`` commands open, with their swarm,
endpoint and key options) listens to the heartbeats and asks every platform heard for its
status every ``--poll`` seconds; a :class:`~actorswarm.ground.recorder.SwarmRecorder`
writes the poses, the actors' switches, the masters, the joins and leaves, vehicle faults
and the platforms' answers to the operator's commands (what a recorder can see of those:
see :mod:`actorswarm.ground.recorder`) to the MCAP file OUT as they come
(:class:`~actorswarm.recording.McapSink`), and with ``--live`` to a Foxglove WebSocket view.
A progress line on stderr says how much was recorded. Ctrl-C (or ``--duration``) ends the
recording and completes the file. The open chunk is written out every
:data:`FLUSH_EVERY` seconds, so a recorder killed outright (SIGKILL, a crash) leaves a file
readable up to about that long before it died (a power failure may also lose what the
operating system had not yet written to the disk).

The platforms answer one ground-station session at a time, the newest: while another
``gs`` command runs (a deploy, an event), the recorder's requests go unanswered. Once that
session has been quiet for a while, the recorder renews its own (a new incarnation) and an
event ``gap`` says how long it had no status.
"""

from __future__ import annotations

import asyncio
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from actorswarm.cli.common import run_async
from actorswarm.cli.record_cmd import LIVE_PORT, LiveHostOpt, LiveOpt, LivePortOpt, OriginOpt
from actorswarm.cli.swarm_options import LinkOptions, link_options

if TYPE_CHECKING:
    from actorswarm.daemon.ground import GroundSession

__all__ = ["gs_record", "register"]

#: Seconds between two progress lines (and two looks at the heartbeats and scene snapshots).
_PROGRESS = 0.5
#: Seconds of recording at most lost when the recorder is killed (the open chunk's span).
FLUSH_EVERY = 1.0
#: Seconds without an answer, and without another session heard, before renewing (long
#: enough for the operator's next command of a sequence, deploy then start, to begin).
_DISPLACED = 3.0


@link_options
def gs_record(
    out: Annotated[Path, typer.Argument(help="The recording to write (MCAP).")],
    conn: LinkOptions,
    poll: Annotated[
        float, typer.Option(min=0.2, max=60.0, help="Seconds between two status requests.")
    ] = 0.5,
    duration: Annotated[
        float | None,
        typer.Option(min=0.5, help="Stop after this many seconds (default: at Ctrl-C)."),
    ] = None,
    name: Annotated[
        str, typer.Option(help="The recording's name (plot titles); default: the swarm's.")
    ] = "",
    origin: OriginOpt = None,
    live: LiveOpt = False,
    live_host: LiveHostOpt = "127.0.0.1",
    live_port: LivePortOpt = LIVE_PORT,
    min_separation: Annotated[
        float,
        typer.Option(
            min=0.01,
            metavar="M",
            help="Every pair of airborne platforms must keep M metres: each breach of it in "
            "the reported positions is recorded and said (default: a quadrotor's 3 m).",
        ),
    ] = 3.0,
) -> None:
    """Record a real swarm (poses, actors' switches, masters, joins and leaves, vehicle
    faults, the platforms' answers to the operator's commands) until Ctrl-C, as an MCAP
    recording like sim --record's: open it in Foxglove, draw it with plot, replay it with
    web --replay. --live also serves it to Foxglove as it happens."""
    from actorswarm.cli.record_cmd import open_live, parse_origin_option
    from actorswarm.daemon.loop import clock
    from actorswarm.engine import commands as cmds
    from actorswarm.ground.membership import Membership
    from actorswarm.ground.recorder import SwarmRecorder
    from actorswarm.ground.separation import SwarmSeparation
    from actorswarm.recording import McapSink, Recorder, RecordingWriteError, Sink
    from actorswarm.world.separation import separation_line

    ln = conn.link()
    meta = {
        "name": name or f"swarm {ln.swarm}",
        "swarm": ln.swarm,
        "source": "gs record",
        "started": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "poll_s": poll,
    }
    frame = parse_origin_option(origin)
    try:
        sinks: list[Sink] = [McapSink(out, flush_every=FLUSH_EVERY, clock=time.monotonic)]
    except RecordingWriteError as exc:
        typer.echo(str(exc), err=True)
        raise typer.Exit(2) from None
    if live:
        try:
            sinks.append(open_live(live_host, live_port, f"gs record {ln.swarm}"))
        except typer.Exit:
            sinks[0].close()
            raise
    writer = Recorder(sinks, meta=meta, t0_ns=time.time_ns(), origin=frame)
    session = ln.session()
    recorder = SwarmRecorder(writer, clock())
    separation = SwarmSeparation(min_separation, max_age=max(3 * poll, 1.0))
    membership = Membership(session.station.config.t_leave)
    show = sys.stderr.isatty()

    def progress(final: bool = False) -> str:
        lines = writer.counts
        text = (
            f"recording {out}: {clock() - recorder.t0:6.1f} s, "
            f"{len(membership.alive())} platforms up, {lines.get('pose', 0)} poses, "
            f"{lines.get('transition', 0)} transitions, {lines.get('master', 0)} master changes, "
            f"{recorder.commands} command answers"
        )
        if show or final:
            typer.echo(("\r" if show else "") + text, err=True, nl=final)
        return text

    def ask(gs: GroundSession, platforms: list[int]) -> None:
        if platforms:
            gs.do(lambda st, t: st.send(cmds.Status(), platforms, t))

    async def go() -> None:
        async with session as gs:
            station = gs.station
            next_poll = clock() + min(poll, 1.0)  # heartbeats first: who is there
            next_look = clock()
            end = None if duration is None else clock() + duration
            answered = clock()
            while end is None or clock() < end:
                for record in station.replies:
                    # Besides status: other sessions' commands answered (the module doc).
                    recorder.reply(record.t, record.platform, record.reply)
                    if isinstance(record.reply, cmds.StatusReply):
                        answered = record.t
                        if record.reply.position is not None:
                            separation.position(record.t, record.platform, record.reply.position)
                station.replies.clear()
                now = clock()
                if (
                    membership.alive()
                    and now - answered > max(3 * poll, _DISPLACED)
                    and now - station.other_session_heard > _DISPLACED
                ):
                    # Another operator's session displaced this one and is done: renew.
                    gs.renew()
                    writer.event(
                        recorder.t(now),
                        "gap",
                        0,
                        f"no status since {recorder.t(answered):.1f} s (another ground station?)",
                    )
                    answered = now
                if now >= next_look:
                    for breach in separation.observe(now):
                        writer.event(recorder.t(now), "separation", 0, breach.describe())
                    membership.update(station, now)
                    recorder.membership(now, membership)
                    progress()
                    next_look = now + _PROGRESS
                if now >= next_poll:
                    ask(gs, membership.alive())
                    next_poll = now + poll
                await asyncio.sleep(0.02)

    try:
        run_async(go())
    except KeyboardInterrupt:
        pass  # Ctrl-C: the normal end of a recording
    except RecordingWriteError as exc:
        typer.echo(f"\n{exc}", err=True)
        raise typer.Exit(1) from None
    except OSError as exc:
        typer.echo(f"\nthe link to the swarm failed: {exc}", err=True)
        raise typer.Exit(1) from None
    finally:
        try:
            writer.close()
        except RecordingWriteError as exc:
            typer.echo(f"\n{exc}", err=True)
    if show:
        typer.echo("", err=True)
    progress(final=True)
    typer.echo(separation_line(separation.result().as_dict()))
    typer.echo(f"wrote {out}")


def register(gs_app: typer.Typer) -> None:
    """Add ``record`` to the ``gs`` command group."""
    gs_app.command("record")(gs_record)
