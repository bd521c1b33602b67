"""The Actor state machine on the collective core: events, candidacies, releases, and the
master's relays and actor table (the theory of operation is :mod:`actorswarm.engine.engine`'s).

:class:`ActorMachine` is a part :class:`~actorswarm.engine.engine.TaskEngine` holds, and
knows nothing of the operator: an application message on a topic that is not the machine's
own goes to the handler its owner registered for that topic (``topics``: the engine's
operator commands), and the owner steers the machine through a few named calls
(:meth:`~ActorMachine.switch`, :meth:`~ActorMachine.forced`, :meth:`~ActorMachine.announce`,
:meth:`~ActorMachine.drop_candidacies`, :meth:`~ActorMachine.undecodable`). It runs alone
too: a host that needs no operator drives it exactly as it drives the engine."""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Final

import msgspec

from actorswarm.core.events import (
    AppReceived,
    BarrierFired,
    BarrierReleased,
    BarrierStaleNotice,
    BecameMaster,
    CoreEvent,
    MasterChanged,
    MemberJoined,
    MemberLeft,
)
from actorswarm.core.node import Node
from actorswarm.core.wire import GROUND_STATION, NEED_ALL, BarrierRequest
from actorswarm.dsl.model import Transition
from actorswarm.engine.groups import SharedEvents, part_need
from actorswarm.engine.plan import Plan
from actorswarm.engine.promotion import (
    BID_WINDOW,
    LOST_SUFFIX,
    Whereabouts,
    lost_bid,
    lost_groups,
)
from actorswarm.engine.records import Cause, FiredRecord, TransitionRecord
from actorswarm.engine.runtime import ActorContext, ActorHost, Emitted
from actorswarm.engine.slots import scatter, scattered_slot, scattered_successor
from actorswarm.runtime.collective import PLUGIN_KEY_BASE, plugin_view
from actorswarm.runtime.storage import BackupStore, MemoryBackupStore

__all__ = [
    "TOPIC_ACTORS",
    "TOPIC_EVENT",
    "TOPIC_MASTER_ACTORS",
    "TOPIC_MISSED",
    "TOPIC_SWARM_EVENT",
    "TOPIC_WHEREABOUTS",
    "ActorMachine",
    "AppHandler",
]

#: What a part does with an application message on a topic it answers: ``(message, now)``.
AppHandler = Callable[[AppReceived, float], None]

#: App-message topics between engines.
TOPIC_ACTORS = "engine.actors"  # member -> master: the actors I run now
TOPIC_SWARM_EVENT = "engine.swarm-event"  # member -> master: relay this event to all
TOPIC_EVENT = "engine.event"  # master -> member: an event for you
TOPIC_MASTER_ACTORS = "engine.master-actors"  # master -> members: the actors I run
TOPIC_WHEREABOUTS = "engine.whereabouts"  # where I am and my roles (promotion.Whereabouts)
TOPIC_MISSED = "engine.missed"  # master -> member back in the swarm: an event it missed


class _EventMsg(msgspec.Struct, frozen=True):
    event: str
    origin: int
    data: Any = None
    occasion: str = ""


_ENCODE = msgspec.msgpack.Encoder()
_DECODE_EVENT = msgspec.msgpack.Decoder(_EventMsg)
_DECODE_ACTORS = msgspec.msgpack.Decoder(list[str])


@dataclass(slots=True)
class _Candidacy:
    actor: str
    transition: Transition
    fallback_at: float | None
    occasion: str
    bid: float | None = None  # asked again with the same bid and data after a stale notice
    data: Any = None
    #: Asked for an event the master says this platform missed (_catch_up): a release of
    #: the group that went without it is one it was not there for, so it asks again.
    missed: bool = False


class ActorMachine:
    """The Actor state machine of platform ``node.platform`` for one task script, on the
    core: events, candidacies, releases and the master's relays.

    A host drives it with :meth:`start` (or :meth:`resume`), :meth:`tick`,
    :meth:`on_core_event` and :meth:`inject`, asks :meth:`next_deadline`, and drains
    :attr:`transitions`, :attr:`ignored` and :attr:`fired`. ``topics`` maps each
    application topic another part answers to its handler, called with every message on
    that topic that reaches this platform (the machine neither decodes nor logs those);
    the machine's own topics are the ``TOPIC_*`` of this module."""

    def __init__(
        self,
        node: Node,
        plan: Plan,
        runtime: ActorHost,
        *,
        grace: float | None = None,
        store: BackupStore | None = None,
        topics: Mapping[str, AppHandler] | None = None,
    ):
        own = set(topics or ()) & set(_APP_HANDLERS)
        if own:
            raise ValueError(f"topic {sorted(own)[0]!r} is the Actor machine's own; pick another")
        self._topics: dict[str, AppHandler] = dict(topics or {})
        self.node = node
        self.plan = plan
        self.runtime = runtime
        cfg = node.config
        self.grace = grace if grace is not None else cfg.t_leave + cfg.t_join
        self.transitions: list[TransitionRecord] = []
        self.ignored: list[tuple[float, str, str]] = []
        #: (Master) transition groups released; the host drains them.
        self.fired: list[FiredRecord] = []
        self._pending: dict[int, _Candidacy] = {}
        # Master side: who runs which actor (from the members' reports). Changed only
        # through _run_table/_forget_table/_reset_table, which count the changes: what each
        # group part waits for is kept while neither the table nor the view changes.
        self._table: dict[int, tuple[str, ...]] = {}
        self._table_version = 0
        # How many rows of the table hold each actor: whether anybody else still runs one
        # is then a lookup, not a walk over the swarm (_catch_up, on every platform's join).
        self._runners: Counter[str] = Counter()
        # Platforms whose catch-up waits for every member's row (a new master's table).
        self._deferred: set[int] = set()
        self._needs: dict[tuple[int, int, int], int] = {}
        self._needs_for: tuple[int, int] = (-1, -1)
        # Member side: what the master runs, so that whoever succeeds a dead master can
        # announce its actors lost.
        self._master_actors: tuple[int, tuple[str, ...]] | None = None
        self._occasions = 0
        # Where platforms running an actor the script's X_lost rules watch last were.
        self._whereabouts = Whereabouts()
        #: The time of the latest call into the engine: the master's slot assignment asks
        #: where the slots are "now", and the core's scatter hook carries no time.
        self._now = 0.0
        #: Where the ``backup`` command writes (atomically); a restarted platform resumes
        #: from its latest backup (:meth:`resume`).
        self.store: BackupStore = store if store is not None else MemoryBackupStore()
        # Shared events heard, for the master to forward (engine/groups.py).
        self._shared = SharedEvents()
        node.resolve_need = self._need
        node.scatter = self._scatter
        # A transition's request data (the event's data, where the platform is) is for the
        # master's slot assignment; gathering it to every participant would make each
        # release chunk carry all N platforms' data. A plugin's barrier still gathers.
        node.gathers = lambda key: key not in self.plan.groups
        runtime.use_script(plan.script)

    # --- host interface ---------------------------------------------------------------

    def start(self, now: float) -> None:
        """Start this platform's initial actors (the task's ``start``)."""
        self._now = now
        for actor in self.plan.initial_actors(self.node.platform):
            if actor not in self.runtime.running():
                try:
                    self.runtime.start(actor, now, ActorContext())
                except ValueError as exc:
                    self.ignored.append((now, "", f"start of {actor} refused: {exc}"))
                    continue
                self.transitions.append(
                    TransitionRecord(
                        t=now,
                        platform=self.node.platform,
                        src="",
                        dst=actor,
                        event="",
                        cause="start",
                    )
                )
        self.announce(now)

    def resume(self, now: float) -> bool:
        """After a restart: bring back the actors of the latest backup (False: none, the
        caller starts the task's initial actors instead)."""
        data = self.store.latest()
        if data is None:
            return False
        try:
            self.runtime.restore(data, now)
        except (ValueError, KeyError, TypeError) as exc:
            self.ignored.append((now, "", f"backup not restored: {exc}"))
            return False
        for actor in self.runtime.running():
            self.transitions.append(
                TransitionRecord(
                    t=now, platform=self.node.platform, src="", dst=actor, event="", cause="start"
                )
            )
        self.announce(now)
        return True

    def tick(self, now: float) -> None:
        self._now = now
        for emitted in self.runtime.step(now):
            self._emitted(emitted, now)
        self._report_whereabouts(now)
        for key, cand in list(self._pending.items()):
            if cand.fallback_at is not None and now >= cand.fallback_at:
                # No release in time: no master could be reached. Decide alone.
                del self._pending[key]
                self.node.barriers.cancel(key)
                target = cand.transition.timeout_branch
                if target is not None and cand.actor in self.runtime.running():
                    self.switch(cand.actor, target, now, cand.transition.event, "timeout")

    def next_deadline(self) -> float | None:
        times = [c.fallback_at for c in self._pending.values() if c.fallback_at is not None]
        runtime = self.runtime.next_deadline()
        if runtime is not None:
            times.append(runtime)
        report = self._whereabouts.next_check(
            watched=self._whereabouts.watching(self.plan, self.runtime.running())
        )
        if report is not None:
            times.append(report)
        return min(times) if times else None

    def inject(
        self,
        event: str,
        now: float,
        *,
        data: Any = None,
        bid: float | None = None,
        occasion: str = "",
        shared: bool = False,
    ) -> None:
        """An event from the ground station reached this platform; ``occasion`` names this
        sending of it (the same on every platform it reached). ``shared``: it was sent to
        the whole swarm, so a master may forward it to a platform that enters an actor
        while a group waits on it (engine/groups.py); a local event is not."""
        if shared:
            self._shared.remember(occasion, event, GROUND_STATION, data)
        self._on_event(event, now, bid=bid, data=data, occasion=occasion)

    def _new_occasion(self) -> str:
        """A name for one occurrence of an event raised here, unique in the swarm."""
        self._occasions += 1
        return f"{self.node.platform}.{self.node.incarnation}:{self._occasions}"

    def on_core_event(self, event: CoreEvent, now: float) -> None:
        self._now = now
        answer = plugin_view(event)
        if answer is not None:
            self.runtime.deliver(answer)
            return
        if isinstance(event, BarrierReleased):
            self._released(event, now)
        elif isinstance(event, BarrierStaleNotice):
            self._stale(event, now)
        elif isinstance(event, AppReceived):
            self._app(event, now)
        elif isinstance(event, BarrierFired):
            if event.key < PLUGIN_KEY_BASE:  # a transition group, not a plugin's barrier
                self.fired.append(
                    FiredRecord(
                        t=now,
                        key=event.key,
                        generation=event.generation,
                        outcome=event.outcome,
                        chosen=tuple(sorted(event.chosen)),
                    )
                )
        elif isinstance(event, MasterChanged):
            self._whereabouts.reset()
            if event.master is not None and event.master != self.node.platform:
                self.announce(now)  # the new master must know what I run
        elif isinstance(event, BecameMaster):
            self._reset_table()
            previous = self._master_actors
            if (
                previous is not None
                and previous[0] != self.node.platform
                and previous[0] not in self.node.members
            ):
                # My predecessor is gone with its actors: nobody else can say so.
                self._master_actors = None
                self._relay_lost(previous[0], previous[1], now)
            self._whereabouts.reset()
            self.announce(now)
        elif isinstance(event, MemberJoined) and self.node.is_master:
            # A newcomer must know what the master runs, in case it succeeds it.
            body = _ENCODE.encode(list(self.runtime.running()))
            self.node.send_app(event.platform, TOPIC_MASTER_ACTORS, body, now)
        elif isinstance(event, MemberLeft) and self.node.is_master:
            self._relay_lost(event.platform, self._forget_table(event.platform), now)
            self._deferred.discard(event.platform)
            self._catch_up_deferred(now)  # it may have been the last row missing

    # --- events and candidacy -----------------------------------------------------------

    def _emitted(self, emitted: Emitted, now: float) -> None:
        occasion = self._new_occasion()
        if emitted.scope == "swarm":
            msg = _EventMsg(emitted.event, self.node.platform, emitted.data, occasion)
            self.node.send_app(None, TOPIC_SWARM_EVENT, _ENCODE.encode(msg), now)
        self._on_event(emitted.event, now, bid=emitted.bid, data=emitted.data, occasion=occasion)

    def _on_event(
        self,
        event: str,
        now: float,
        *,
        bid: float | None,
        data: Any,
        occasion: str,
        missed: bool = False,
    ) -> None:
        handled = False
        if bid is None:  # X_lost: the nearest to where the lost platform was goes first
            bid = lost_bid(event, data, self.runtime.position())
        for actor in self.runtime.running():
            found = self.plan.by_event.get((actor, event))
            if found is None:
                continue
            handled = True
            key, part = found
            if key in self._pending:
                continue  # already a candidate of this group
            self._request(
                actor, key, part, now, bid=bid, data=data, occasion=occasion, missed=missed
            )
        if not handled:
            running = ", ".join(self.runtime.running()) or "no actor"
            self.ignored.append((now, event, f"no transition for it from {running}"))

    def _request(
        self,
        actor: str,
        key: int,
        part: int,
        now: float,
        *,
        bid: float | None,
        data: Any,
        occasion: str,
        missed: bool = False,
    ) -> None:
        group = self.plan.groups[key]
        transition = group.parts[part]
        timeout = group.timeout
        self._pending[key] = _Candidacy(
            actor,
            transition,
            None if timeout is None else now + timeout + self.grace,
            occasion,
            bid,
            data,
            missed,
        )
        at = self.runtime.position()
        self.node.request_barrier(
            key,
            group.need(),
            now,
            part=part,
            bid=bid,
            # Where this platform is rides along, for the master's slot assignment.
            data={"event": data, "at": None if at is None else [at[0], at[1], at[2]]},
            timeout=timeout,
            occasion=occasion,
            # Told the generation is stale, this platform asks again for the open one
            # (_stale): the master may do that for it, saving the round trip.
            renew=True,
        )

    def _released(self, event: BarrierReleased, now: float) -> None:
        cand = self._pending.pop(event.key, None)
        if cand is None or cand.actor not in self.runtime.running():
            return
        transition = cand.transition
        if event.outcome == "timeout":
            if transition.timeout_branch is not None:
                # Those who waited leave together, each with the place the timeout firing
                # gave it among them, as a release's do: a formation actor they go to has a
                # slot per aircraft (without one every aircraft flew to the same point).
                slot, slots = scattered_slot(event.data) or (
                    (event.index, event.size) if 1 <= event.index <= event.size else (0, 0)
                )
                context = ActorContext(
                    index=event.index, data=event.data, size=event.size, slot=slot, slots=slots
                )
                self.switch(
                    cand.actor, transition.timeout_branch, now, transition.event, "timeout", context
                )
            return
        if not event.chosen:
            if cand.missed:
                # The swarm took this transition while this platform was away: the release
                # named those who were there. Follow it on the group's next release.
                self._ask_again(cand, now)
            return
        target = scattered_successor(event.data, transition) or self.plan.successor(
            transition, event.index
        )
        slot, slots = scattered_slot(event.data) or self.plan.placement(
            transition, event.index, event.size
        )
        self.switch(
            cand.actor,
            target,
            now,
            transition.event,
            "barrier",
            ActorContext(
                params=transition.param_map,
                index=event.index,
                data=event.data,
                size=event.size,
                slot=slot,
                slots=slots,
            ),
        )

    def _stale(self, event: BarrierStaleNotice, now: float) -> None:
        """The request named a generation that had fired before it was made (this platform
        missed a release it was not part of): ask again for the open one."""
        cand = self._pending.pop(event.key, None)
        if cand is None or cand.actor not in self.runtime.running():
            return
        self._ask_again(cand, now)

    def _ask_again(self, cand: _Candidacy, now: float) -> None:
        """Request the group of ``cand`` (no longer pending) again, for its open generation,
        with the same bid, data and occasion."""
        found = self.plan.by_event.get((cand.actor, cand.transition.event))
        if found is not None:
            self._request(
                cand.actor,
                found[0],
                found[1],
                now,
                bid=cand.bid,
                data=cand.data,
                occasion=cand.occasion,
            )

    def switch(
        self,
        src: str,
        dst: str,
        now: float,
        event: str,
        cause: Cause,
        context: ActorContext | None = None,
    ) -> None:
        """Switch the running actor ``src`` to ``dst`` (a release, a timeout, or the
        operator's forced transition), record it and tell the master what runs now; a switch
        the runtime refuses is logged in :attr:`ignored` and changes nothing."""
        try:
            self.runtime.switch(src, dst, now, context or ActorContext())
        except ValueError as exc:  # refused by the runtime (hardware busy, bad params, ...)
            self.ignored.append((now, event, f"switch {src} -> {dst} refused: {exc}"))
            self.announce(now)
            return
        self.transitions.append(
            TransitionRecord(
                t=now, platform=self.node.platform, src=src, dst=dst, event=event, cause=cause
            )
        )
        # A candidacy of the actor that just left is void.
        for key in [k for k, c in self._pending.items() if c.actor == src]:
            del self._pending[key]
            self.node.barriers.cancel(key)
        self.announce(now)

    def forced(self, src: str, dst: str, now: float) -> None:
        """The operator started ``dst`` (``src`` empty) or stopped ``src`` (``dst`` empty)
        through the runtime: record it (cause ``forced``) and tell the master what runs now."""
        self.transitions.append(
            TransitionRecord(
                t=now, platform=self.node.platform, src=src, dst=dst, event="", cause="forced"
            )
        )
        self.announce(now)

    def drop_candidacies(self) -> None:
        """A new version of the script: every candidacy of the old one is void, its barrier
        request cancelled."""
        for key in list(self._pending):
            self.node.barriers.cancel(key)
        self._pending.clear()

    # --- master side ----------------------------------------------------------------------

    def announce(self, now: float) -> None:
        """Tell the master what this platform runs now (the master: enter it in its own
        table and tell every member)."""
        running = self.runtime.running()
        if self.node.is_master:
            before = self._run_table(self.node.platform, running)
            # One broadcast to every member, not one message each: O(1) packets per switch.
            self.node.post_bulletin(TOPIC_MASTER_ACTORS, _ENCODE.encode(list(running)), now)
            self._entered(self.node.platform, before, now)
        else:
            self.node.send_app(None, TOPIC_ACTORS, _ENCODE.encode(list(running)), now)

    def _app(self, msg: AppReceived, now: float) -> None:
        """An application message: to the owner's handler of its topic, or to the machine's
        own (:data:`_APP_HANDLERS`); a topic neither answers is not for this engine."""
        answer = self._topics.get(msg.topic)
        if answer is not None:
            answer(msg, now)
            return
        handler = _APP_HANDLERS.get(msg.topic)
        if handler is None:
            return
        try:
            handler(self, msg, now)
        except msgspec.DecodeError:
            self.undecodable(msg, now)

    # --- one handler per topic of the machine's own (the table _APP_HANDLERS) -----------

    def _on_actors(self, msg: AppReceived, now: float) -> None:
        """A member runs these actors now (the master enters them in its table)."""
        before = self._run_table(msg.sender, tuple(_DECODE_ACTORS.decode(msg.body)))
        if self.node.is_master:
            self._entered(msg.sender, before, now)

    def _on_whereabouts(self, msg: AppReceived, now: float) -> None:
        self._whereabouts.heard(msg.sender, msg.body)

    def _on_master_actors(self, msg: AppReceived, now: float) -> None:
        """What the master runs, for whoever succeeds it to announce them lost."""
        self._master_actors = (msg.sender, tuple(_DECODE_ACTORS.decode(msg.body)))

    def _on_swarm_event(self, msg: AppReceived, now: float) -> None:
        """Master: a member raised an event for the whole swarm; relay it."""
        if self.node.is_master:
            ev = _DECODE_EVENT.decode(msg.body)
            self._relay(ev.event, ev.data, origin=ev.origin, now=now, occasion=ev.occasion)

    def _on_event_msg(self, msg: AppReceived, now: float) -> None:
        """The master relayed (or forwarded) an event to this platform."""
        ev = _DECODE_EVENT.decode(msg.body)
        self._shared.remember(ev.occasion, ev.event, ev.origin, ev.data)
        self._on_event(ev.event, now, bid=None, data=ev.data, occasion=ev.occasion)

    def _on_missed(self, msg: AppReceived, now: float) -> None:
        """The master forwarded an event sent while this platform was out of the swarm;
        one it heard after all (its occasion remembered) is not handled twice."""
        ev = _DECODE_EVENT.decode(msg.body)
        if self._shared.get(ev.occasion) is not None:
            return
        self._shared.remember(ev.occasion, ev.event, ev.origin, ev.data)
        self._on_event(ev.event, now, bid=None, data=ev.data, occasion=ev.occasion, missed=True)

    def undecodable(self, msg: AppReceived, now: float) -> None:
        """Log an application message whose body did not decode (and carry on)."""
        self.ignored.append((now, msg.topic, f"undecodable message from {msg.sender}"))

    def _relay_lost(self, platform: int, actors: tuple[str, ...], now: float) -> None:
        """Master: ``platform`` left; relay ``X_lost`` for each of its ``actors``, with
        where it last was, after holding the groups those events fire, so that the
        candidates' bids (their distances to that place) decide rather than who asks first."""
        if not actors:
            # Nothing to relay; and a master that has just taken over hears of its
            # predecessor leaving before it relays its actors lost: keep its whereabouts.
            return
        data = self._whereabouts.lost(platform)
        events = [f"{actor}{LOST_SUFFIX}" for actor in actors]
        for key in lost_groups(self.plan, events):
            self.node.hold_barrier(key, now + BID_WINDOW)
        for event in events:
            self._relay(event, data, origin=0, now=now)

    def _report_whereabouts(self, now: float) -> None:
        """Tell the master (the master: every member) where I am and the roles I hold,
        when :class:`~actorswarm.engine.promotion.Whereabouts` says a report is due."""
        whereabouts = self._whereabouts
        watched = whereabouts.watching(self.plan, self.runtime.running())
        if watched and whereabouts.waiting(now):
            return  # no report before the interval is over: the vehicle need not be read
        body = whereabouts.due(
            now,
            watched=watched,
            # Unwatched, due only forgets the last report: the position is not read either.
            position=self.runtime.position() if watched else None,
            roles=self.node.roles.held,
        )
        if body is None:
            return
        if self.node.is_master:
            self.node.post_bulletin(TOPIC_WHEREABOUTS, body, now)
        elif self.node.master is not None:
            self.node.send_app(None, TOPIC_WHEREABOUTS, body, now)
        else:
            self._whereabouts.reset()  # nobody to tell: report to the next master at once

    def _relay(self, event: str, data: Any, *, origin: int, now: float, occasion: str = "") -> None:
        """Master: send ``event`` to every member but its origin (one broadcast, resent only
        to those that do not acknowledge), and handle it here."""
        occasion = occasion or self._new_occasion()
        self._shared.remember(occasion, event, origin, data)
        body = _ENCODE.encode(_EventMsg(event, origin, data, occasion))
        self.node.post_bulletin(TOPIC_EVENT, body, now, skip=(origin,) if origin else ())
        if origin != self.node.platform:
            self._on_event(event, now, bid=None, data=data, occasion=occasion)

    @property
    def plan(self) -> Plan:
        """The script this platform runs, compiled. A new one (a new version started, a
        restart) also drops the needs the master kept: what a group part waits for follows
        the script's transitions, not only the table and the view."""
        return self._plan

    @plan.setter
    def plan(self, plan: Plan) -> None:
        self._plan = plan
        self._needs_for = (-1, -1)

    def _reset_table(self) -> None:
        """A new master: the table holds what this platform runs, nobody else yet."""
        running = self.runtime.running()
        self._table = {self.node.platform: running}
        self._runners = Counter(running)
        self._deferred = set()
        self._table_version += 1

    def _run_table(self, platform: int, running: tuple[str, ...]) -> tuple[str, ...] | None:
        """``platform`` runs ``running`` now; what the table said before (None: nothing)."""
        before = self._table.get(platform)
        self._table[platform] = running
        if running != before:
            self._table_version += 1
            self._runners.subtract(before or ())
            self._runners.update(running)
        return before

    def _forget_table(self, platform: int) -> tuple[str, ...]:
        """``platform`` left: its row, removed (empty when it had none)."""
        self._table_version += 1
        row = self._table.pop(platform, ())
        self._runners.subtract(row)
        return row

    def _need(self, key: int, part: int, count: int) -> int:
        """What part ``part`` of group ``key`` waits for (engine/groups.py); a plugin's
        barrier (no transition) waits for its number, or every live platform.

        The core asks on every request it gets and every table change, and the answer
        takes a pass over the live platforms; it is kept until the table or the view
        changes, so a switch of N platforms costs the master O(N), not O(N²)."""
        stamp = (self._table_version, self.node.members.version)
        if stamp != self._needs_for:
            self._needs.clear()
            self._needs_for = stamp
        need = self._needs.get((key, part, count))
        if need is None:
            need = self._needs[(key, part, count)] = self._resolve(key, part, count)
        return need

    def _resolve(self, key: int, part: int, count: int) -> int:
        live = (*self.node.members.peers, self.node.platform)
        transition = self.plan.transition(key, part)
        if transition is None:
            return len(live) if count == NEED_ALL else count
        return part_need(transition, count, self._table, live, self.plan.reach)

    def _entered(self, platform: int, before: tuple[str, ...] | None, now: float) -> None:
        """Master: ``platform`` now runs what the table says. A group whose part it left or
        entered may be complete now; one it entered that waits on a shared event gets it
        forwarded (engine/groups.py)."""
        running = self._table.get(platform, ())
        entered = set(running) - set(before or ())
        changed = entered | (set(before or ()) - set(running))
        reach = self.plan.reach
        # Groups whose need may have moved: a part's actor, or one leading to it, changed.
        touched = [
            key
            for key, group in self.plan.groups.items()
            if any(not reach.get(t.actor, {t.actor}).isdisjoint(changed) for t in group.parts)
        ]
        if before is not None and entered:
            for key, group in self.plan.groups.items():
                if not any(t.actor in entered for t in group.parts):
                    continue
                for occasion in self.node.waiting_occasions(key):
                    shared = self._shared.get(occasion)
                    if shared is None or not any(t.event == shared[0] for t in group.parts):
                        continue
                    event, origin, data = shared
                    if platform == self.node.platform:
                        self._on_event(event, now, bid=None, data=data, occasion=occasion)
                    else:
                        body = _ENCODE.encode(_EventMsg(event, origin, data, occasion))
                        self.node.send_app(platform, TOPIC_EVENT, body, now)
        if before is None and platform != self.node.platform:
            self._catch_up(platform, running, now)
            self._catch_up_deferred(now)
        if touched or before is None:
            self.node.needs_changed(now, None if before is None else touched)

    def _catch_up(self, platform: int, running: tuple[str, ...], now: float) -> None:
        """Master: ``platform`` has joined the swarm (booted late, rebooted and resumed
        its backup, or was cut off) running ``running``. Where no other platform runs one
        of those actors any more, the swarm has left it, and did so on the latest shared
        event that takes every platform of that actor (``sysNum="all"``) that this master
        remembers: forward it, so that the platform follows. It ignores one it heard after
        all, and follows a release that went without it (TOPIC_MISSED). An exact
        ``sysNum`` picks some platforms: those picked took it, nobody else is to."""
        # The table holds ``running`` as this platform's row: an actor it alone runs has
        # as many rows as it appears in ``running``.
        alone = [a for a in running if self._runners[a] <= running.count(a)]
        if not alone:
            return
        if not self._table_complete():
            # Not every member has said what it runs yet (a new master): nobody can tell
            # whether the swarm has left an actor. Asked again once all have.
            self._deferred.add(platform)
            return
        plan = self.plan
        shared = self._shared.newest_first()
        for actor in alone:
            for occasion, event, origin, data in shared:
                found = plan.by_event.get((actor, event))
                if found is not None and plan.groups[found[0]].parts[found[1]].sys_num == "all":
                    body = _ENCODE.encode(_EventMsg(event, origin, data, occasion))
                    self.node.send_app(platform, TOPIC_MISSED, body, now)
                    break

    def _table_complete(self) -> bool:
        """Master: whether every member of the view has a row in the table."""
        table = self._table
        return all(p in table for p in self.node.members.peers)

    def _catch_up_deferred(self, now: float) -> None:
        """Master: the catch-ups put off while the table was incomplete (a platform that
        rejoined a new master before the others had all reported), once it is complete."""
        if not self._deferred or not self._table_complete():
            return
        # Each is in the table: a row leaves it only with its platform (MemberLeft, which
        # drops it from here too) or with the whole table (a new master, which clears this).
        deferred, self._deferred = self._deferred, set()
        for platform in sorted(deferred):
            self._catch_up(platform, self._table[platform], now)

    def _scatter(
        self, key: int, generation: int, chosen: list[tuple[int, int, int, BarrierRequest]]
    ) -> dict[int, Any]:
        """The core's scatter hook (master): where each chosen participant goes
        (:func:`~actorswarm.engine.slots.scatter`)."""
        return scatter(self.plan, self.runtime, key, chosen, self._now)


#: The handler of each application topic of the machine's own.
_APP_HANDLERS: Final[dict[str, Callable[[ActorMachine, AppReceived, float], None]]] = {
    TOPIC_ACTORS: ActorMachine._on_actors,
    TOPIC_WHEREABOUTS: ActorMachine._on_whereabouts,
    TOPIC_MASTER_ACTORS: ActorMachine._on_master_actors,
    TOPIC_SWARM_EVENT: ActorMachine._on_swarm_event,
    TOPIC_EVENT: ActorMachine._on_event_msg,
    TOPIC_MISSED: ActorMachine._on_missed,
}
