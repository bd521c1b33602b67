"""``actorswarm gs ros2``: run the ground bridge (:mod:`actorswarm.ros2.bridge`) until Ctrl-C.

The command's options are the other ``gs`` commands' (swarm, Zenoh endpoints, keys) and the
bridge's own. Without a usable rclpy it says what to install or source and exits 2; a ROS 2
error while it runs (a wrong type on the event topic, a message that does not decode) is
printed on stderr naming the topic, and the bridge goes on.
"""

from __future__ import annotations

import asyncio
import functools
import time
from typing import TYPE_CHECKING, Annotated

import typer

from actorswarm.cli.swarm_options import LinkOptions, link_options

if TYPE_CHECKING:
    from actorswarm.cli.swarm_options import Link
    from actorswarm.ground.station import GroundStation
    from actorswarm.ros2.bridge import BridgeSettings

__all__ = ["gs_ros2", "register"]

#: Seconds without a status answer, and without another session heard, before the bridge
#: renews its session (another ``gs`` command displaced it and is done), as ``gs record``.
_DISPLACED = 3.0


@link_options
def gs_ros2(
    conn: LinkOptions,
    frame: Annotated[
        str, typer.Option(help="The frame id of the mission's ENU frame in the messages.")
    ] = "map",
    origin: Annotated[
        str | None,
        typer.Option(help="LAT,LON,ALT of the mission's origin: also publish NavSatFix."),
    ] = None,
    commands: Annotated[
        bool,
        typer.Option(
            "--commands",
            help="Offer the operator's actions as ROS 2 services and an event topic, "
            "signed with the operator's key: anyone on the ROS 2 graph can then command "
            "the swarm.",
        ),
    ] = False,
    poll: Annotated[
        float, typer.Option(min=0.2, max=60.0, help="Seconds between two status requests.")
    ] = 0.5,
    rate: Annotated[float, typer.Option(min=0.2, max=50.0, help="Publications per second.")] = 5.0,
    duration: Annotated[
        float | None,
        typer.Option(min=0.5, help="Stop after this many seconds (default: at Ctrl-C)."),
    ] = None,
    domain: Annotated[
        int | None,
        typer.Option(min=0, max=232, help="The ROS 2 domain (default: ROS_DOMAIN_ID, or 0)."),
    ] = None,
) -> None:
    """Put the swarm on ROS 2 topics under /SWARM/ (poses, actors, roles, vehicle state,
    master, membership, RViz markers) until Ctrl-C; with --commands, take the operator's actions
    from ROS 2 services (docs/ros2.md)."""
    from actorswarm.ros2.bridge import BridgeSettings, parse_origin
    from actorswarm.ros2.load import Ros2Error

    try:
        geodetic = None if origin is None else parse_origin(origin)
    except ValueError as exc:
        typer.echo(str(exc), err=True)
        raise typer.Exit(2) from None
    ln = conn.link()
    settings = BridgeSettings(frame=frame, origin=geodetic, commands=commands)
    try:
        asyncio.run(_run(ln, settings, poll, rate, duration, domain))
    except KeyboardInterrupt:
        pass
    except Ros2Error as exc:
        typer.echo(str(exc), err=True)
        raise typer.Exit(2) from None
    except OSError as exc:
        typer.echo(f"the link to the swarm failed: {exc}", err=True)
        raise typer.Exit(1) from None


async def _run(
    ln: Link,
    settings: BridgeSettings,
    poll: float,
    rate: float,
    duration: float | None,
    domain: int | None,
) -> None:
    from actorswarm.daemon.loop import clock
    from actorswarm.ros2.bridge import GroundBridge, GroundView, describe
    from actorswarm.ros2.node import RosNode

    def report(text: str) -> None:
        typer.echo(f"{time.strftime('%H:%M:%S')} {text}", err=True)

    node = RosNode("ground_bridge", f"/{ln.swarm}", domain_id=domain)
    try:
        node.start()
        session = ln.session()
        async with session as gs:
            view = GroundView(gs.station.config.t_leave)
            bridge = GroundBridge(node, ln.swarm, settings)
            if settings.commands:
                bridge.enable_commands(asyncio.get_running_loop(), gs.do)
            for what, text in describe(settings, ln.swarm).items():
                report(f"ros2 {what}: {text}")
            started = clock()
            end = None if duration is None else started + duration
            next_poll = clock() + min(poll, 1.0)  # heartbeats first: who is there
            while end is None or clock() < end:
                now = clock()
                view.update(gs.station, now)
                bridge.publish(view)
                for error in node.drain_errors():
                    report(f"ros2: {error}")
                for action in bridge.actions:
                    report(f"operator (ROS 2): {action}")
                bridge.actions.clear()
                answered = view.answered if view.answered is not None else started
                if (
                    view.alive()
                    and now - answered > max(3 * poll, _DISPLACED)
                    and now - gs.station.other_session_heard > _DISPLACED
                ):
                    gs.renew()  # another operator's session displaced this one and is done
                    view.answered = now
                if now >= next_poll:
                    alive = view.alive()
                    if alive:
                        gs.do(functools.partial(_ask_status, alive))
                    next_poll = now + poll
                await asyncio.sleep(1.0 / rate)
    finally:
        node.close()


def _ask_status(platforms: list[int], station: GroundStation, now: float) -> None:
    from actorswarm.engine import commands as cmds

    station.send(cmds.Status(), platforms, now)


def register(gs_app: typer.Typer) -> None:
    """Add ``ros2`` to the ``gs`` command group (ROS 2 is imported only when it runs)."""
    gs_app.command("ros2")(gs_ros2)
