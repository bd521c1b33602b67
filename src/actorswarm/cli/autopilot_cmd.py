"""``actorswarm autopilot``: a simulated MAVLink autopilot (ArduCopter or PX4) for one
vehicle, until SIGTERM or SIGINT (:mod:`actorswarm.vehicles.mavlink.autopilot`).

pymavlink is imported only when the command runs.
"""

from __future__ import annotations

import signal
import sys
import threading
from enum import StrEnum
from typing import Annotated

import typer

__all__ = ["autopilot"]


class AutopilotKind(StrEnum):
    ardupilot = "ardupilot"
    px4 = "px4"


def autopilot(
    home: Annotated[
        str,
        typer.Option(help="Where it stands: LAT,LON,ALT (degrees, degrees, metres AMSL)."),
    ],
    listen: Annotated[
        str,
        typer.Option(help="Its MAVLink endpoint, as pymavlink writes it (a daemon's udpout:)."),
    ] = "udpin:127.0.0.1:14560",
    sysid: Annotated[int, typer.Option(min=1, max=255, help="Its MAVLink system ID.")] = 1,
    kind: Annotated[
        AutopilotKind, typer.Option(help="Which autopilot it behaves as.")
    ] = AutopilotKind.ardupilot,
    failsafes: Annotated[
        bool,
        typer.Option(
            "--failsafes/--no-failsafes",
            help="Its link-loss and battery failsafe parameters on (1) or off (0).",
        ),
    ] = True,
    battery: Annotated[
        float, typer.Option(min=0.01, max=1.0, help="The charge at start, 0..1.")
    ] = 1.0,
    endurance: Annotated[
        float, typer.Option(min=1.0, help="Seconds of flight on a full battery at cruise speed.")
    ] = 1200.0,
    ready_after: Annotated[
        float | None,
        typer.Option(
            min=0.0,
            help="Seconds from boot until it accepts arming, refusing with the real "
            "autopilot's reasons before (default: as measured, 40 for ardupilot, 35 for px4). "
            "On tcpin: its clock starts when the first client connects.",
        ),
    ] = None,
) -> None:
    """Run a simulated MAVLink autopilot (quadrotor) for one vehicle until SIGTERM/SIGINT."""
    from actorswarm.vehicles.mavlink import MavlinkError
    from actorswarm.vehicles.mavlink.autopilot import AutopilotOptions, SimAutopilot
    from actorswarm.vehicles.mavlink.frame import parse_origin

    try:
        options = AutopilotOptions(
            listen,
            parse_origin(home, what="--home"),
            system=sysid,
            kind=kind.value,
            failsafes=failsafes,
            battery=battery,
            endurance=endurance,
            ready_after=ready_after,
        )
        sim = SimAutopilot(options)
    except (ValueError, MavlinkError) as exc:
        typer.echo(
            f"autopilot: {exc}" if not str(exc).startswith("autopilot") else str(exc), err=True
        )
        raise typer.Exit(2) from None
    stop = threading.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: stop.set())
    print(
        f"autopilot {sysid} ({kind.value}) on {listen}, home {home}, "
        f"ready to arm {sim.boot.ready_after:g} s after boot",
        file=sys.stderr,
        flush=True,
    )
    try:
        sim.run(stop)
    finally:
        sim.close()
