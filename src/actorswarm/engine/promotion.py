"""Who replaces a lost platform: where it last was, and each candidate's bid for its place.

Theory of operation
-------------------
When a member leaves, the master relays ``X_lost`` for every actor ``X`` it ran, and every
platform whose running actor has a transition on ``X_lost`` is a candidate. A ``sysNum="1"``
rule promotes the first candidate to ask (the master, a candidate itself, asks at once), or
the best bid of those asking together — with the default bids the lowest platform ID —
however far it is from where the lost platform was. So the event carries where the lost
platform last was, each candidate bids its distance to that place, and the master waits
for the bids: the nearest wins.

* **Whereabouts.** A platform running an actor whose loss the script reacts to (some
  transition is on ``X_lost``: :func:`watched_actors`) tells the master where it is and the
  collective roles it holds (:class:`Whereabouts`): on its first report to a master, then
  whenever it moved :data:`REPORT_DISTANCE` metres or its roles changed, at most every
  :data:`REPORT_INTERVAL` seconds. The master itself posts the same report to every member
  (it may be the one lost, and its successor relays its ``X_lost``). Platforms running
  nothing watched send nothing, so a swarm whose script has no ``X_lost`` rule pays nothing.
* **The event's data** (:func:`lost_data`): ``{"platform": ID, "at": [x, y, z] or None,
  "roles": [name, ...]}``: the lost platform, its last reported position (None when it
  never reported one: it ran no watched actor, had no vehicle, or its report did not arrive)
  and the roles it held then (a promoted tracker takes over the lost one's target role:
  :mod:`actorswarm.plugins.tracking`).
* **The wait** (:data:`BID_WINDOW`). The master relays ``X_lost`` and is itself a
  candidate at once, while the others' requests are still on their way: a ``sysNum="1"``
  group would fire on the first request to arrive. So the master holds the groups with a
  transition on the events it relays (:func:`lost_groups`,
  :meth:`~actorswarm.core.node.Node.hold_barrier`) for :data:`BID_WINDOW` seconds, and
  then chooses among every bid that arrived.
* **The bid** (:func:`lost_bid`): a candidate's horizontal distance in metres to ``at``
  (lower wins, ties by platform ID, as every bid). A candidate that does not know where it
  is bids :data:`NO_POSITION_BID`, behind every candidate that does. When ``at`` is None
  every candidate keeps the default bid (its platform ID), as before positions were known.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any, Final

import msgspec

from actorswarm.engine.plan import Plan

__all__ = [
    "BID_WINDOW",
    "LOST_SUFFIX",
    "NO_POSITION_BID",
    "REPORT_DISTANCE",
    "REPORT_INTERVAL",
    "Whereabouts",
    "lost_bid",
    "lost_data",
    "lost_groups",
    "lost_position",
    "watched_actors",
]

#: The built-in event ``X_lost`` is the actor's name followed by this.
LOST_SUFFIX: Final = "_lost"
#: A watched platform reports again once it is this many metres from its last report.
REPORT_DISTANCE: Final = 15.0
#: ...but not more often than this (seconds).
REPORT_INTERVAL: Final = 2.0
#: How long the master lets the candidates' bids for ``X_lost`` gather before it chooses:
#: the relay and the request each take a hop, and a lost packet is resent within 0.2 s
#: (the core's ``retry_cap``), so this allows a retry or two each way.
BID_WINDOW: Final = 0.5
#: The bid of a candidate that does not know where it is: behind any distance.
NO_POSITION_BID: Final = 1e9


class _Report(msgspec.Struct, frozen=True, array_like=True, forbid_unknown_fields=True):
    """What a watched platform tells the master: where it is and the roles it holds."""

    at: tuple[float, float, float] | None
    roles: tuple[str, ...] = ()


_ENCODE = msgspec.msgpack.Encoder()
_DECODE = msgspec.msgpack.Decoder(_Report)


def watched_actors(plan: Plan) -> frozenset[str]:
    """The actors whose loss the plan's script reacts to: those ``X`` with a transition on
    ``X_lost`` somewhere in the script."""
    names = {a.name for a in plan.script.actors}
    cut = len(LOST_SUFFIX)
    return frozenset(
        e[:-cut] for _, e in plan.by_event if e.endswith(LOST_SUFFIX) and e[:-cut] in names
    )


def lost_groups(plan: Plan, events: Iterable[str]) -> set[int]:
    """The core barrier keys of the plan's groups with a transition on one of ``events``."""
    wanted = set(events)
    return {key for (_, event), (key, _) in plan.by_event.items() if event in wanted}


def lost_data(
    platform: int, at: Sequence[float] | None = None, roles: Iterable[str] = ()
) -> dict[str, Any]:
    """The data of ``X_lost`` for ``platform``: where it last was (None: not known) and the
    roles it held then."""
    return {
        "platform": platform,
        "at": None if at is None else [float(v) for v in at],
        "roles": list(roles),
    }


def lost_position(data: Any) -> tuple[float, float] | None:
    """Where the lost platform was, from ``X_lost`` data (:func:`lost_data`); None when the
    data holds no sound position (unknown, or not ``X_lost`` data at all)."""
    if not isinstance(data, dict) or not isinstance(data.get("platform"), int):
        return None
    at = data.get("at")
    if not isinstance(at, list) or len(at) not in (2, 3):
        return None
    if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in at):
        return None
    x, y = float(at[0]), float(at[1])
    return (x, y) if math.isfinite(x) and math.isfinite(y) else None


def lost_bid(event: str, data: Any, position: Sequence[float] | None) -> float | None:
    """A candidate's bid for ``event`` when it is an ``X_lost`` carrying the lost platform's
    position: its horizontal distance to it, or :data:`NO_POSITION_BID` when ``position``
    (where the candidate is) is unknown. None (the default bid) for any other event or
    when the lost platform's position is unknown."""
    if not event.endswith(LOST_SUFFIX):
        return None
    where = lost_position(data)
    if where is None:
        return None
    here = _point(position)
    if here is None:
        return NO_POSITION_BID
    return math.hypot(here[0] - where[0], here[1] - where[1])


def _point(position: Sequence[float] | None) -> tuple[float, float, float] | None:
    """``position`` as ``(x, y, z)`` (z 0 when it has two coordinates); None when unknown
    or not finite."""
    if position is None or len(position) < 2:
        return None
    x, y = float(position[0]), float(position[1])
    z = float(position[2]) if len(position) > 2 else 0.0
    return (x, y, z) if all(math.isfinite(v) for v in (x, y, z)) else None


class Whereabouts:
    """Both sides of the reports: what this platform last reported (and whether it is due
    to report again), and the latest report heard from each other platform."""

    def __init__(self) -> None:
        self._heard: dict[int, _Report] = {}
        self._sent: _Report | None = None
        self._sent_at = -math.inf
        self._checked_at = -math.inf  # the last time a report was considered
        self._watched: tuple[Plan, frozenset[str]] | None = None

    def watching(self, plan: Plan, running: Iterable[str]) -> bool:
        """Whether one of the ``running`` actors is watched under ``plan``."""
        if self._watched is None or self._watched[0] is not plan:
            self._watched = (plan, watched_actors(plan))
        watched = self._watched[1]
        return bool(watched) and any(a in watched for a in running)

    # --- reporting -------------------------------------------------------------------------

    def reset(self) -> None:
        """A new master: it has heard nothing from this platform yet."""
        self._sent, self._sent_at, self._checked_at = None, -math.inf, -math.inf

    def due(
        self,
        now: float,
        *,
        watched: bool,
        position: Sequence[float] | None,
        roles: Iterable[str],
    ) -> bytes | None:
        """The report to send now (encoded), or None when none is due: this platform runs
        no watched actor, or it is close to where it last reported with the same roles, or
        it reported less than :data:`REPORT_INTERVAL` seconds ago."""
        if not watched:
            # Whatever it runs next, it reports afresh when that is watched again.
            self.reset()
            return None
        if self.waiting(now):
            return None
        self._checked_at = now
        at = _point(position)
        report = _Report(at=at, roles=tuple(sorted(roles)))
        last = self._sent
        if last is not None and last.roles == report.roles:
            if last.at is None and at is None:
                return None
            if last.at is not None and at is not None and math.dist(last.at, at) < REPORT_DISTANCE:
                return None
        self._sent, self._sent_at = report, now
        return _ENCODE.encode(report)

    def waiting(self, now: float) -> bool:
        """Whether :meth:`due` would answer None at ``now`` for a watched actor whatever
        the position and roles, for want of time (:data:`REPORT_INTERVAL` not over): a
        host may then skip reading its vehicle's position."""
        return now < max(self._sent_at, self._checked_at) + REPORT_INTERVAL

    def next_check(self, *, watched: bool) -> float | None:
        """When to ask :meth:`due` again (None: not while nothing watched runs): every
        :data:`REPORT_INTERVAL` seconds while something watched runs."""
        if not watched or self._checked_at == -math.inf:
            return None
        return max(self._sent_at, self._checked_at) + REPORT_INTERVAL

    # --- hearing -----------------------------------------------------------------------------

    def heard(self, platform: int, body: bytes) -> None:
        """Keep ``platform``'s report; msgspec.DecodeError when ``body`` is not one."""
        self._heard[platform] = _DECODE.decode(body)

    def lost(self, platform: int) -> dict[str, Any]:
        """``platform`` left: the data of its ``X_lost`` (:func:`lost_data`); its report is
        forgotten (it may come back elsewhere, with other roles)."""
        report = self._heard.pop(platform, None)
        if report is None:
            return lost_data(platform)
        return lost_data(platform, report.at, report.roles)
