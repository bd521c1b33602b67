"""Where the chosen participants of a transition group go: the master decides, the
release scatters it, each member reads its share.

Only the master sees every part of a group, so it computes, for each chosen participant,
the successor actor and a slot among everyone the firing sends there (:func:`scatter`,
the core's scatter hook). A member takes them from its release with
:func:`scattered_successor` and :func:`scattered_slot`, which refuse anything unsound (a
release from an older master, a damaged one); the member then computes its own.
"""

from __future__ import annotations

import math
from typing import Any

from actorswarm.core.wire import BarrierRequest
from actorswarm.dsl.model import Transition
from actorswarm.engine.assign import assign_slots
from actorswarm.engine.plan import Plan
from actorswarm.engine.runtime import ActorHost

__all__ = ["scatter", "scattered_slot", "scattered_successor"]


def scatter(
    plan: Plan,
    runtime: ActorHost,
    key: int,
    chosen: list[tuple[int, int, int, BarrierRequest]],
    now: float,
) -> dict[int, Any]:
    """Each chosen participant's successor, and its slot among everyone the firing
    sends to that successor: ``{"to": actor, "slot": k, "slots": n}``, plus ``"event"``:
    the data of the event it became a candidate for, when there was any, and
    ``"centre"``: the mean ``[x, y]`` of the positions of everyone sent to that successor,
    when every one of them said where it was.

    Slots are counted across the parts of a group (two transitions sharing a key, such
    as the paper's merge of B and C into D), in part then index order, so a merged
    formation gets one slot per member rather than two members per slot; only the
    master sees every part, which is why it is computed here and scattered. ``now`` is
    the time the successor's places are asked for (a moving formation's are not fixed)."""
    going: dict[str, list[tuple[int, int, int]]] = {}
    params: dict[str, dict[str, str]] = {}
    where: dict[int, Any] = {}
    said: dict[int, Any] = {}
    for platform, part, index, request in chosen:
        transition = plan.transition(key, part)
        if transition is not None:
            successor = plan.successor(transition, index)
            going.setdefault(successor, []).append((part, index, platform))
            params.setdefault(successor, transition.param_map)
            if isinstance(request.data, dict):
                where[platform] = request.data.get("at")
                said[platform] = request.data.get("event")
    out: dict[int, Any] = {}
    for successor, members in going.items():
        members.sort()
        order = [platform for _, _, platform in members]
        slots = _assigned(runtime, successor, order, where, params[successor], now)
        centre = _centre([where.get(p) for p in order])
        for platform, slot in zip(order, slots, strict=True):
            entry: dict[str, Any] = {"to": successor, "slot": slot, "slots": len(members)}
            if centre is not None:
                # One point every member of the group knows: a group that must move
                # together (flight.return_home's rally) translates by the same vector.
                entry["centre"] = centre
            if said.get(platform) is not None:
                # The data of the event that made it a candidate (a detection's target
                # position): the successor's plugins find it in ctx.data["event"].
                entry["event"] = said[platform]
            out[platform] = entry
    return out


def _assigned(
    runtime: ActorHost,
    successor: str,
    order: list[int],
    where: dict[int, Any],
    params: dict[str, str],
    now: float,
) -> list[int]:
    """Slots for the members in ``order`` (part then index order): by least total
    distance to the successor's places (squared, when they move in step) when its plugins
    give places and every member said where it is; otherwise in that order."""
    in_order = list(range(1, len(order) + 1))
    said = [where.get(p) for p in order]
    if len(order) < 2 or not all(_is_xy(p) for p in said):
        return in_order
    positions: list[list[float]] = [list(p) for p in said if isinstance(p, list)]
    points = runtime.group_points(successor, len(order), now, params)
    if points is None:
        return in_order
    squared = runtime.group_in_step(successor, len(order), now, params)
    return assign_slots(positions, points[: len(order)], squared=squared)


def _centre(said: list[Any]) -> list[float] | None:
    """The mean ``[x, y]`` of the members' positions, or None unless every member said
    where it was."""
    if not said or not all(_is_xy(p) for p in said):
        return None
    return [
        sum(float(p[0]) for p in said) / len(said),
        sum(float(p[1]) for p in said) / len(said),
    ]


def scattered_successor(data: Any, transition: Transition) -> str | None:
    """The successor the master scattered for this participant (it sees every part of a
    group), or None when the data names none of the transition's successors (a release
    from an older master, or a damaged one): the member then computes it itself."""
    if not isinstance(data, dict):
        return None
    to = data.get("to")
    return to if isinstance(to, str) and to in transition.successors else None


def scattered_slot(data: Any) -> tuple[int, int] | None:
    """The ``(slot, slots)`` the master scattered (:func:`scatter`), or None
    when the data does not hold a sound pair (a release from an older master)."""
    if not isinstance(data, dict):
        return None
    slot, slots = data.get("slot"), data.get("slots")
    if (
        isinstance(slot, int)
        and isinstance(slots, int)
        and not isinstance(slot, bool)
        and not isinstance(slots, bool)
        and 1 <= slot <= slots
    ):
        return slot, slots
    return None


def _is_xy(value: Any) -> bool:
    """A position a request carried: a list of 2 or 3 finite numbers."""
    return (
        isinstance(value, list)
        and len(value) in (2, 3)
        and all(
            isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
            for v in value
        )
    )
