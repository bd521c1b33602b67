"""The task engine: one platform's Actor state machine, run on the collective core.

Theory of operation
-------------------
The engine is sans-IO like the core it drives: a host hands it the core's events
(:meth:`TaskEngine.on_core_event`), ground-station events (:meth:`TaskEngine.inject`) and
time (:meth:`TaskEngine.tick`), and it acts through the core :class:`~actorswarm.core.Node`
and an :class:`~actorswarm.engine.runtime.ActorHost`.

* **Events.** An event reaches a platform locally (a plugin emitted it with scope ``local``,
  or the ground station sent it) or through the master (scope ``swarm``: the emitter sends it
  to the master, which relays it to every member). A platform whose running actor has a
  transition for the event becomes a *candidate*: it asks to pass the core barrier of the
  transition's group, in the transition's part, with its bid and data. Otherwise the event
  is ignored and logged.
* **Firing.** The master fires a group once every part that can have candidates has its
  ``sysNum`` of them (``all``: every holder of the part's actor in the master's view, from
  the actor table the members keep it informed of; a part nobody holds, or nobody can
  reach, waits for nobody: :mod:`actorswarm.engine.groups`); the release gives each chosen
  candidate its index and scatters its successor and slot (the master sees every part of
  a group); a member uses them, and computes the branch with :meth:`Plan.successor` only
  when a release carries none. Candidates not chosen stay where they are.
* **Relays.** The master relays an event (and tells what it runs) to every member as one
  broadcast bulletin, resent only to the members that do not acknowledge it.
* **Timeouts.** The master releases the waiting candidates of an overdue group with outcome
  ``timeout``; they go to ``timeoutBranch`` (or stay, when there is none). A candidate that
  hears no release by ``timeout`` plus a grace period falls back to ``timeoutBranch`` on its
  own (it cannot reach any master).
* **Lost actors.** When a member leaves the master's view, the master relays the swarm event
  ``X_lost`` for every actor ``X`` it was running, with where the platform last said it was
  and the roles it held; candidates bid their distance to that place, so the nearest
  replaces it (:mod:`actorswarm.engine.promotion`).
* **Ground-station commands** (:mod:`actorswarm.engine.commands`, from platform 0 only):
  deploy in chunks (answered with the script's SHA-256), start (the first script, or a new
  version while running), inject an event, forced transition, forced start / stop, pause /
  activate, backup and status. Each is answered with its outcome.
* **Records.** What the host may want to report is kept in lists it drains:
  :attr:`TaskEngine.transitions` (every switch), :attr:`TaskEngine.commands` (every operator
  command carried out) and, on the master, :attr:`TaskEngine.fired` (every transition group
  it released).
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

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
from actorswarm.engine import commands as cmds
from actorswarm.engine.assign import assign_slots
from actorswarm.engine.groups import SharedEvents, part_need
from actorswarm.engine.plan import Plan
from actorswarm.engine.promotion import (
    BID_WINDOW,
    LOST_SUFFIX,
    Whereabouts,
    lost_bid,
    lost_groups,
)
from actorswarm.engine.runtime import ActorContext, ActorHost, Emitted
from actorswarm.runtime.collective import PLUGIN_KEY_BASE, plugin_view
from actorswarm.runtime.storage import BackupStore, MemoryBackupStore

if TYPE_CHECKING:
    from actorswarm.dsl.checker import CheckResult

Cause = Literal["barrier", "timeout", "forced", "start"]

#: App-message topics between engines.
TOPIC_ACTORS = "engine.actors"  # member -> master: the actors I run now
TOPIC_SWARM_EVENT = "engine.swarm-event"  # member -> master: relay this event to all
TOPIC_EVENT = "engine.event"  # master -> member: an event for you
TOPIC_MASTER_ACTORS = "engine.master-actors"  # master -> members: the actors I run
TOPIC_WHEREABOUTS = "engine.whereabouts"  # where I am and my roles (promotion.Whereabouts)


class _EventMsg(msgspec.Struct, frozen=True):
    event: str
    origin: int
    data: Any = None
    occasion: str = ""


_ENCODE = msgspec.msgpack.Encoder()
_DECODE_EVENT = msgspec.msgpack.Decoder(_EventMsg)
_DECODE_ACTORS = msgspec.msgpack.Decoder(list[str])


@dataclass(frozen=True, slots=True, kw_only=True)
class TransitionRecord:
    """One actor switch of one platform."""

    t: float
    platform: int
    src: str
    dst: str
    event: str
    cause: Cause


@dataclass(frozen=True, slots=True, kw_only=True)
class CommandRecord:
    """One operator command this platform carried out at ``t``: its name (``Inject``,
    ``Start``...), the event for an ``Inject`` ("" otherwise) and whether it succeeded."""

    t: float
    command: str
    event: str
    ok: bool


@dataclass(frozen=True, slots=True, kw_only=True)
class FiredRecord:
    """Master only: at ``t`` it released generation ``generation`` of the transition group
    ``key`` to the platforms ``chosen`` (``outcome``: ``complete`` or ``timeout``)."""

    t: float
    key: int
    generation: int
    outcome: str
    chosen: tuple[int, ...]


@dataclass(slots=True)
class _Candidacy:
    actor: str
    transition: Transition
    fallback_at: float | None
    occasion: str
    bid: float | None = None  # asked again with the same bid and data after a stale notice
    data: Any = None


class TaskEngine:
    """The Actor state machine of platform ``node.platform`` for one task script."""

    def __init__(
        self,
        node: Node,
        plan: Plan,
        runtime: ActorHost,
        *,
        grace: float | None = None,
        store: BackupStore | None = None,
    ):
        self.node = node
        self.plan = plan
        self.runtime = runtime
        cfg = node.config
        self.grace = grace if grace is not None else cfg.t_leave + cfg.t_join
        self.transitions: list[TransitionRecord] = []
        self.ignored: list[tuple[float, str, str]] = []
        #: Operator commands carried out, and (master) groups released; the host drains them.
        self.commands: list[CommandRecord] = []
        self.fired: list[FiredRecord] = []
        self._pending: dict[int, _Candidacy] = {}
        # Master side: who runs which actor (from the members' reports).
        self._table: dict[int, tuple[str, ...]] = {}
        # Member side: what the master runs, so that whoever succeeds a dead master can
        # announce its actors lost.
        self._master_actors: tuple[int, tuple[str, ...]] | None = None
        self._occasions = 0
        # Where platforms running an actor the script's X_lost rules watch last were.
        self._whereabouts = Whereabouts()
        #: The time of the latest call into the engine: the master's slot assignment asks
        #: where the slots are "now", and the core's scatter hook carries no time.
        self._now = 0.0
        # Ground-station deployment: chunks being reassembled, scripts confirmed, the one run.
        self._chunks: dict[str, dict[int, bytes]] = {}
        self._deployed: dict[str, Plan] = {}
        self.script_sha = ""
        #: Where the ``backup`` command writes (atomically); a restarted platform resumes
        #: from its latest backup (:meth:`resume`).
        self.store: BackupStore = store if store is not None else MemoryBackupStore()
        #: Called with ``(sha256, script bytes)`` when a deployment completes, and with the
        #: hash when a script starts: a daemon keeps both in its state directory.
        self.on_deployed: Callable[[str, bytes], None] | None = None
        self.on_started: Callable[[str], None] | None = None
        # Shared events heard, for the master to forward (engine/groups.py).
        self._shared = SharedEvents()
        node.resolve_need = self._need
        node.scatter = self._scatter
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
        self._announce(now)

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
        self._announce(now)
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
                    self._switch(cand.actor, target, now, cand.transition.event, "timeout")

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
                self._announce(now)  # the new master must know what I run
        elif isinstance(event, BecameMaster):
            self._table = {self.node.platform: self.runtime.running()}
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
            self._announce(now)
        elif isinstance(event, MemberJoined) and self.node.is_master:
            # A newcomer must know what the master runs, in case it succeeds it.
            body = _ENCODE.encode(list(self.runtime.running()))
            self.node.send_app(event.platform, TOPIC_MASTER_ACTORS, body, now)
        elif isinstance(event, MemberLeft) and self.node.is_master:
            self._relay_lost(event.platform, self._table.pop(event.platform, ()), now)

    # --- events and candidacy -----------------------------------------------------------

    def _emitted(self, emitted: Emitted, now: float) -> None:
        occasion = self._new_occasion()
        if emitted.scope == "swarm":
            msg = _EventMsg(emitted.event, self.node.platform, emitted.data, occasion)
            self.node.send_app(None, TOPIC_SWARM_EVENT, _ENCODE.encode(msg), now)
        self._on_event(emitted.event, now, bid=emitted.bid, data=emitted.data, occasion=occasion)

    def _on_event(
        self, event: str, now: float, *, bid: float | None, data: Any, occasion: str
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
            self._request(actor, key, part, now, bid=bid, data=data, occasion=occasion)
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
        )

    def _released(self, event: BarrierReleased, now: float) -> None:
        cand = self._pending.pop(event.key, None)
        if cand is None or cand.actor not in self.runtime.running():
            return
        transition = cand.transition
        if event.outcome == "timeout":
            if transition.timeout_branch is not None:
                self._switch(
                    cand.actor, transition.timeout_branch, now, transition.event, "timeout"
                )
            return
        if not event.chosen:
            return
        target = _scattered_successor(event.data, transition) or self.plan.successor(
            transition, event.index
        )
        slot, slots = _scattered_slot(event.data) or self.plan.placement(
            transition, event.index, event.size
        )
        self._switch(
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

    def _switch(
        self,
        src: str,
        dst: str,
        now: float,
        event: str,
        cause: Cause,
        context: ActorContext | None = None,
    ) -> None:
        try:
            self.runtime.switch(src, dst, now, context or ActorContext())
        except ValueError as exc:  # refused by the runtime (hardware busy, bad params, ...)
            self.ignored.append((now, event, f"switch {src} -> {dst} refused: {exc}"))
            self._announce(now)
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
        self._announce(now)

    # --- master side ----------------------------------------------------------------------

    def _announce(self, now: float) -> None:
        running = self.runtime.running()
        if self.node.is_master:
            before = self._table.get(self.node.platform)
            self._table[self.node.platform] = running
            # One broadcast to every member, not one message each: O(1) packets per switch.
            self.node.post_bulletin(TOPIC_MASTER_ACTORS, _ENCODE.encode(list(running)), now)
            self._entered(self.node.platform, before, now)
        else:
            self.node.send_app(None, TOPIC_ACTORS, _ENCODE.encode(list(running)), now)

    def _app(self, msg: AppReceived, now: float) -> None:
        try:
            if msg.topic == cmds.TOPIC_COMMAND:
                if msg.sender == GROUND_STATION:
                    self._command(cmds.decode_command(msg.body), now)
                return
            if msg.topic == TOPIC_ACTORS:
                before = self._table.get(msg.sender)
                self._table[msg.sender] = tuple(_DECODE_ACTORS.decode(msg.body))
                if self.node.is_master:
                    self._entered(msg.sender, before, now)
            elif msg.topic == TOPIC_WHEREABOUTS:
                self._whereabouts.heard(msg.sender, msg.body)
            elif msg.topic == TOPIC_MASTER_ACTORS:
                self._master_actors = (msg.sender, tuple(_DECODE_ACTORS.decode(msg.body)))
            elif msg.topic == TOPIC_SWARM_EVENT and self.node.is_master:
                ev = _DECODE_EVENT.decode(msg.body)
                self._relay(ev.event, ev.data, origin=ev.origin, now=now, occasion=ev.occasion)
            elif msg.topic == TOPIC_EVENT:
                ev = _DECODE_EVENT.decode(msg.body)
                self._shared.remember(ev.occasion, ev.event, ev.origin, ev.data)
                self._on_event(ev.event, now, bid=None, data=ev.data, occasion=ev.occasion)
        except (msgspec.DecodeError, cmds.CommandError):
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
        body = self._whereabouts.due(
            now,
            watched=self._whereabouts.watching(self.plan, self.runtime.running()),
            position=self.runtime.position(),
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

    def _need(self, key: int, part: int, count: int) -> int:
        """What part ``part`` of group ``key`` waits for (engine/groups.py); a plugin's
        barrier (no transition) waits for its number, or every live platform."""
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
        if touched or before is None:
            self.node.needs_changed(now, None if before is None else touched)

    def _scatter(
        self, key: int, generation: int, chosen: list[tuple[int, int, int, BarrierRequest]]
    ) -> dict[int, Any]:
        """Each chosen participant's successor, and its slot among everyone the firing
        sends to that successor: ``{"to": actor, "slot": k, "slots": n}``, plus ``"event"``:
        the data of the event it became a candidate for, when there was any.

        Slots are counted across the parts of a group (two transitions sharing a key, such
        as the paper's merge of B and C into D), in part then index order, so a merged
        formation gets one slot per member rather than two members per slot; only the
        master sees every part, which is why it is computed here and scattered."""
        going: dict[str, list[tuple[int, int, int]]] = {}
        params: dict[str, dict[str, str]] = {}
        where: dict[int, Any] = {}
        said: dict[int, Any] = {}
        for platform, part, index, request in chosen:
            transition = self.plan.transition(key, part)
            if transition is not None:
                successor = self.plan.successor(transition, index)
                going.setdefault(successor, []).append((part, index, platform))
                params.setdefault(successor, transition.param_map)
                if isinstance(request.data, dict):
                    where[platform] = request.data.get("at")
                    said[platform] = request.data.get("event")
        out: dict[int, Any] = {}
        for successor, members in going.items():
            members.sort()
            order = [platform for _, _, platform in members]
            slots = self._assigned(successor, order, where, params[successor])
            for platform, slot in zip(order, slots, strict=True):
                entry: dict[str, Any] = {"to": successor, "slot": slot, "slots": len(members)}
                if said.get(platform) is not None:
                    # The data of the event that made it a candidate (a detection's target
                    # position): the successor's plugins find it in ctx.data["event"].
                    entry["event"] = said[platform]
                out[platform] = entry
        return out

    def _assigned(
        self, successor: str, order: list[int], where: dict[int, Any], params: dict[str, str]
    ) -> list[int]:
        """Slots for the members in ``order`` (part then index order): by least total
        distance to the successor's places when its plugins give places and every member
        said where it is; otherwise in that order."""
        in_order = list(range(1, len(order) + 1))
        said = [where.get(p) for p in order]
        if len(order) < 2 or not all(_is_xy(p) for p in said):
            return in_order
        positions: list[list[float]] = [list(p) for p in said if isinstance(p, list)]
        points = self.runtime.group_points(successor, len(order), self._now, params)
        if points is None:
            return in_order
        return assign_slots(positions, points[: len(order)])

    # --- ground-station commands ---------------------------------------------------------

    def _reply(self, reply: cmds.Reply, now: float) -> None:
        self.node.send_app(GROUND_STATION, cmds.TOPIC_REPLY, cmds.encode(reply), now, urgent=True)

    def _result(self, command: str, ok: bool, message: str, now: float) -> None:
        self._reply(cmds.Result(command=command, ok=ok, message=message), now)

    def _command(self, command: cmds.Command, now: float) -> None:
        """Carry out one operator command, record it and report its outcome."""
        name = type(command).__name__
        event = command.event if isinstance(command, cmds.Inject) else ""
        try:
            message = self._execute(command, now)
        except (ValueError, KeyError) as exc:
            self.commands.append(CommandRecord(t=now, command=name, event=event, ok=False))
            self._result(name, False, str(exc), now)
            return
        self.commands.append(CommandRecord(t=now, command=name, event=event, ok=True))
        if message is not None:
            self._result(name, True, message, now)

    def _execute(self, command: cmds.Command, now: float) -> str | None:
        if isinstance(command, cmds.DeployChunk):
            return self._deploy_chunk(command, now)
        if isinstance(command, cmds.Start):
            return self._start_script(command.sha256, now)
        if isinstance(command, cmds.Inject):
            running = set(self.runtime.running())
            if command.actors and not running & set(command.actors):
                return f"not running {', '.join(command.actors)}: event {command.event} skipped"
            self.inject(
                command.event,
                now,
                data=command.data,
                occasion=command.occasion,
                shared=not command.actors,
            )
            return f"event {command.event} delivered"
        if isinstance(command, cmds.Force):
            return self._force(command, now)
        if isinstance(command, cmds.ForceStart):
            self._known_actor(command.actor)
            self.runtime.start(command.actor, now, ActorContext())
            self._record("", command.actor, now, "", "forced")
            return f"started {command.actor}"
        if isinstance(command, cmds.ForceStop):
            self.runtime.stop(command.actor, now)
            self._record(command.actor, "", now, "", "forced")
            return f"stopped {command.actor}"
        if isinstance(command, cmds.Pause):
            self.runtime.pause(command.actor, now)
            self._announce(now)
            return f"paused {command.actor}"
        if isinstance(command, cmds.Activate):
            self.runtime.activate(command.actor, now)
            self._announce(now)
            return f"activated {command.actor}"
        if isinstance(command, cmds.Backup):
            snapshot = self.runtime.snapshot()
            generation = self.store.write(snapshot)
            self._reply(cmds.BackupReply(generation=generation, size=len(snapshot)), now)
            return None
        self._reply(self._status(now), now)  # Status
        return None

    def _status(self, now: float | None = None) -> cmds.StatusReply:
        position = self.runtime.position()
        return cmds.StatusReply(
            acbs=self.runtime.status(now),
            actors=self.runtime.loaded(),
            master=self.node.is_master,
            epoch=self.node.epoch,
            incarnation=self.node.incarnation,
            script=self.script_sha,
            position=None if position is None else [round(v, 3) for v in position],
            vehicle=self.runtime.vehicle_state(),
        )

    def _deploy_chunk(self, chunk: cmds.DeployChunk, now: float) -> str | None:
        if chunk.sha256 in self._deployed:
            self._reply(cmds.DeployAck(sha256=chunk.sha256), now)
            return None
        parts = self._chunks.setdefault(chunk.sha256, {})
        parts[chunk.index] = chunk.data
        if len(parts) < chunk.total:
            return None
        del self._chunks[chunk.sha256]
        text = b"".join(parts[i] for i in range(chunk.total))
        if hashlib.sha256(text).hexdigest() != chunk.sha256:
            raise ValueError("the script does not hash to the SHA-256 it was sent with")
        result = _check(text.decode("utf-8", errors="replace"), f"deploy:{chunk.sha256[:12]}")
        if result.script is None or not result.ok:
            first = next((str(d) for d in result.diagnostics), "the script is invalid")
            raise ValueError(f"script refused: {first}")
        self._deployed[chunk.sha256] = Plan.build(result.script)
        if self.on_deployed is not None:
            self.on_deployed(chunk.sha256, text)
        self._reply(cmds.DeployAck(sha256=chunk.sha256), now)
        return None

    def adopt(self, script: bytes) -> str:
        """Register ``script`` as deployed (a daemon restarting with the scripts of its state
        directory); returns its SHA-256. ValueError when the script is invalid."""
        sha = hashlib.sha256(script).hexdigest()
        result = _check(script.decode("utf-8", errors="replace"), f"kept:{sha[:12]}")
        if result.script is None or not result.ok:
            first = next((str(d) for d in result.diagnostics), "the script is invalid")
            raise ValueError(f"script {sha[:12]} refused: {first}")
        self._deployed[sha] = Plan.build(result.script)
        return sha

    def rejoin(self, sha: str, now: float) -> bool:
        """After a restart: run the adopted script ``sha`` again, resuming the actors of the
        latest backup, or starting the initial actors when there is none (returns whether
        a backup was resumed). ValueError when ``sha`` was not adopted."""
        plan = self._deployed.get(sha)
        if plan is None:
            raise ValueError(f"script {sha[:12]} is not known here; adopt it first")
        self.script_sha = sha
        self.plan = plan
        self.runtime.use_script(plan.script)
        if self.resume(now):
            return True
        self.start(now)
        return False

    def _start_script(self, sha: str, now: float) -> str:
        plan = self._deployed.get(sha)
        if plan is None:
            raise ValueError(f"script {sha[:12]} was not deployed to platform {self.node.platform}")
        if self.script_sha == sha:
            return f"script {sha[:12]} already running"
        fresh = not self.script_sha
        self.script_sha = sha
        if self.on_started is not None:
            self.on_started(sha)
        self.runtime.use_script(plan.script)
        if fresh and not self.runtime.running():
            self.plan = plan
            self.start(now)
            return f"started script {sha[:12]}"
        # A new version while running: candidacies of the old one are void; actors the new
        # script does not know stop; a platform left with nothing starts its initial actors.
        for key in list(self._pending):
            self.node.barriers.cancel(key)
        self._pending.clear()
        self.plan = plan
        known = {a.name for a in plan.script.actors}
        for actor in list(self.runtime.loaded()):
            if actor not in known:
                self.runtime.stop(actor, now)
                self._record(actor, "", now, "", "forced")
        if not self.runtime.loaded():
            self.start(now)
        self._announce(now)
        return f"switched to script {sha[:12]}"

    def _known_actor(self, actor: str) -> None:
        if actor not in {a.name for a in self.plan.script.actors}:
            raise ValueError(f"the running script has no actor {actor!r}")

    def _force(self, command: cmds.Force, now: float) -> str:
        self._known_actor(command.to)
        moved = [a for a in self.runtime.running() if command.src is None or a == command.src]
        if not moved:
            return f"nothing to move: not running {command.src}"
        for actor in moved:
            if actor != command.to:
                self._switch(
                    actor, command.to, now, "", "forced", ActorContext(params=dict(command.params))
                )
        return f"{', '.join(moved)} -> {command.to}"

    def _record(self, src: str, dst: str, now: float, event: str, cause: Cause) -> None:
        self.transitions.append(
            TransitionRecord(
                t=now, platform=self.node.platform, src=src, dst=dst, event=event, cause=cause
            )
        )
        self._announce(now)


def _check(text: str, path: str) -> CheckResult:
    """The DSL checker on a script deployed or kept. Imported here, not with the module: the
    checker (parser, rules, plugin discovery through the installed entry points) costs
    memory and start-up time a platform without a script does not need."""
    from actorswarm.dsl.checker import check

    return check(text, path=path)


def _scattered_successor(data: Any, transition: Transition) -> str | None:
    """The successor the master scattered for this participant (it sees every part of a
    group), or None when the data names none of the transition's successors (a release
    from an older master, or a damaged one): the member then computes it itself."""
    if not isinstance(data, dict):
        return None
    to = data.get("to")
    return to if isinstance(to, str) and to in transition.successors else None


def _scattered_slot(data: Any) -> tuple[int, int] | None:
    """The ``(slot, slots)`` the master scattered (:meth:`TaskEngine._scatter`), or None
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
