"""A platform's vehicle as the operator reads it, from what its status reply carries.

A status reply's ``vehicle`` (:class:`~actorswarm.engine.commands.StatusReply`) holds the
scalar entries of the vehicle adapter's own status: a MAVLink vehicle's ``link`` (up or
lost), ``autopilot`` and ``mode``, ``armed``, ``battery`` (a fraction, None when not
reported), the operator's ``override``, or ``error`` when the adapter's status failed;
``ready`` (None before the autopilot is heard), ``waiting`` (seconds a take-off has waited
for it), ``reason`` (why it is not ready: the autopilot's own words when it said any; when ready,
the messages it does not send although asked) and
``refused`` (the last command it refused). A
simulated vehicle says nothing of itself (an empty ``vehicle``). :func:`describe` is the one
wording of it, for ``actorswarm gs status`` and the web ground station alike.
"""

from __future__ import annotations

from collections.abc import Mapping

__all__ = ["alarm", "describe"]


def describe(vehicle: Mapping[str, object]) -> str:
    """``link up, ardupilot GUIDED, armed, battery 87 %, operator hold``, or while a
    take-off waits ``link up, ardupilot GUIDED, disarmed, battery 100 %, not ready 23 s —
    PreArm: Need Position Estimate`` ("" when the vehicle said nothing the operator reads)."""
    parts = [f"link {vehicle['link']}"] if "link" in vehicle else []
    kind = " ".join(str(vehicle[k]) for k in ("autopilot", "mode") if vehicle.get(k))
    if kind:
        parts.append(kind)
    if "armed" in vehicle:
        parts.append("armed" if vehicle["armed"] else "disarmed")
    if vehicle.get("starting"):
        parts.append("starting")  # heard for under 3 s: commands wait for its start-up
    battery = vehicle.get("battery")
    if isinstance(battery, int | float) and not isinstance(battery, bool):
        parts.append(f"battery {100 * battery:.0f} %")
    if vehicle.get("override"):
        parts.append(f"operator {vehicle['override']}")
    if "error" in vehicle:
        parts.append(f"status failed: {vehicle['error']}")
    # Last: the autopilot's reason is free text (it may hold commas).
    waiting = vehicle.get("waiting")
    reason = vehicle.get("reason")
    if isinstance(waiting, int | float) and not isinstance(waiting, bool):
        parts.append(f"not ready {waiting:.0f} s" + (f" — {reason}" if reason else ""))
    elif vehicle.get("ready") is False:
        parts.append("not ready" + (f" — {reason}" if reason else ""))
    elif reason:
        parts.append(str(reason))  # ready, yet something it reads does not come
    return ", ".join(parts)


def alarm(vehicle: Mapping[str, object]) -> bool:
    """True when the operator must look at once: the platform says the link to its vehicle
    is lost (its actors run, but nothing they command reaches the vehicle), or it could not
    read its vehicle's status at all."""
    return vehicle.get("link") == "lost" or "error" in vehicle
