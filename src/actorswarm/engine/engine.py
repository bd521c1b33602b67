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
* **The task's clock.** A start carries its instant on the clock the platforms share (UTC
  on robots, kept by GPS or NTP; the one clock in the simulator): :attr:`TaskEngine.began`.
  The engine turns it into its host's clock (:attr:`TaskEngine.clock_offset`) for the
  plugins, as ``ctx.task_start``, so a schedule counted from the task's start (a formation's
  ``depart``) is one schedule across the swarm, however late the command reached a platform.
  A later start of the same task keeps the first instant.
* **Records.** What the host may want to report is kept in lists it drains:
  :attr:`TaskEngine.transitions` (every switch), :attr:`TaskEngine.commands` (every operator
  command carried out) and, on the master, :attr:`TaskEngine.fired` (every transition group
  it released).

Layout: :class:`TaskEngine` here is the operator's side (deployment and the commands, one
handler each in :data:`_COMMAND_HANDLERS`) and holds the state machine on the core as a part,
:attr:`TaskEngine.machine` (:class:`~actorswarm.engine.machine.ActorMachine`,
:mod:`.machine`), with no inheritance between them: the engine registers its handler for the
command topic with the machine, steers it through a few named calls (switch, forced start or
stop, announce, drop the candidacies of an old script) and hands a host's calls on to it;
where the chosen go is :mod:`.slots`, the records :mod:`.records`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Final

import msgspec

from actorswarm.core.digest import sha256_hex
from actorswarm.core.events import AppReceived
from actorswarm.core.node import Node
from actorswarm.core.wire import GROUND_STATION
from actorswarm.dsl.isolated import ScriptChecker, ScriptRefused, check_in_process
from actorswarm.engine import commands as cmds
from actorswarm.engine.machine import ActorMachine
from actorswarm.engine.plan import Plan
from actorswarm.engine.records import CommandRecord, FiredRecord, TransitionRecord
from actorswarm.engine.runtime import ActorContext, ActorHost
from actorswarm.runtime.storage import BackupStore, MemoryBackupStore

if TYPE_CHECKING:
    from actorswarm.core.events import CoreEvent
    from actorswarm.dsl.model import TaskScript

__all__ = ["CommandRecord", "FiredRecord", "TaskEngine", "TransitionRecord"]


class TaskEngine:
    """The Actor state machine of platform ``node.platform`` for one task script
    (:attr:`machine`), and the ground-station commands that deploy, start, steer and inspect
    it.

    A host drives it as it would the machine alone (:meth:`start` or :meth:`resume`,
    :meth:`tick`, :meth:`on_core_event`, :meth:`inject`, :meth:`next_deadline`) and drains
    :attr:`transitions`, :attr:`ignored`, :attr:`fired` and, the engine's own,
    :attr:`commands`."""

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
        self.runtime = runtime
        #: Where the ``backup`` command writes (atomically); :meth:`resume` reads it back.
        self.store: BackupStore = store if store is not None else MemoryBackupStore()
        #: The Actor state machine; application messages on the command topic come back
        #: to :meth:`_on_command`.
        self.machine = ActorMachine(
            node,
            plan,
            runtime,
            grace=grace,
            store=self.store,
            topics={cmds.TOPIC_COMMAND: self._on_command},
        )
        #: Operator commands carried out; the host drains them.
        self.commands: list[CommandRecord] = []
        # Ground-station deployment: chunks being reassembled, scripts confirmed, the one run.
        self._chunks: dict[str, dict[int, bytes]] = {}
        self._deployed: dict[str, Plan] = {}
        self.script_sha = ""
        #: Called with ``(sha256, script bytes)`` when a deployment completes, and with the
        #: hash when a script starts: a daemon keeps both in its state directory.
        self.on_deployed: Callable[[str, bytes], None] | None = None
        self.on_started: Callable[[str], None] | None = None
        #: Checks a script deployed or kept and gives its model, or raises ScriptRefused
        #: (default: in this process; a daemon checks in a child process, so it never
        #: carries the checker, actorswarm.dsl.isolated).
        self.checker: ScriptChecker = check_in_process
        #: When set (a daemon), a deployed script is checked without blocking: called with
        #: ``(sha256, text)`` once the script is whole, it arranges for :meth:`checked` to
        #: be called with the verdict later; the DeployAck (or the refusal) waits for it.
        self.check_later: Callable[[str, str], None] | None = None
        # Scripts whose verdict check_later owes: the bytes, to keep once it is given.
        self._checking: dict[str, bytes] = {}
        #: The swarm's shared clock minus the host's clock (seconds), read when a start
        #: comes: 0 where they are one clock (the simulator); a daemon's is UTC minus its
        #: monotonic clock.
        self.clock_offset: Callable[[], float] = _one_clock
        #: When the task started, on the swarm's shared clock; None: not started.
        self.began: float | None = None

    def _set_began(self, began: float) -> None:
        self.began = began
        self.runtime.task_start = began - self.clock_offset()

    # --- the host's calls, handed on to the machine ---------------------------------------

    def start(self, now: float, *, began: float | None = None) -> None:
        """Start this platform's initial actors (:meth:`ActorMachine.start`): the task
        starts at ``began`` on the shared clock (None: now, unless a start is known)."""
        self._keep_began(began, now)
        self.machine.start(now)

    def resume(self, now: float, *, began: float | None = None) -> bool:
        """After a restart: bring back the actors of the latest backup (False: none; the
        caller starts the initial actors instead; :meth:`ActorMachine.resume`), in the
        task that started at ``began`` (as :meth:`start`)."""
        self._keep_began(began, now)
        return self.machine.resume(now)

    def _keep_began(self, began: float | None, now: float) -> None:
        """The task's start: ``began``, else the one known, else ``now``."""
        if began is not None:
            self._set_began(began)
        elif self.began is None:
            self._set_began(now + self.clock_offset())

    def tick(self, now: float) -> None:
        """Time passed (:meth:`ActorMachine.tick`)."""
        self.machine.tick(now)

    def next_deadline(self) -> float | None:
        """When :meth:`tick` is due next; None: only an event wakes the engine."""
        return self.machine.next_deadline()

    def on_core_event(self, event: CoreEvent, now: float) -> None:
        """An event of the core (an operator's command among its application messages)."""
        self.machine.on_core_event(event, now)

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
        """An event from the ground station reached this platform
        (:meth:`ActorMachine.inject`)."""
        self.machine.inject(event, now, data=data, bid=bid, occasion=occasion, shared=shared)

    @property
    def plan(self) -> Plan:
        """The script this platform runs, compiled (the machine's)."""
        return self.machine.plan

    @property
    def transitions(self) -> list[TransitionRecord]:
        """Every switch of an actor here; the host drains it (the machine's record)."""
        return self.machine.transitions

    @property
    def ignored(self) -> list[tuple[float, str, str]]:
        """``(time, event or topic, why)`` of each event or message that changed nothing;
        the host drains it (the machine's record)."""
        return self.machine.ignored

    @property
    def fired(self) -> list[FiredRecord]:
        """(Master) transition groups released; the host drains it (the machine's record)."""
        return self.machine.fired

    def _on_command(self, msg: AppReceived, now: float) -> None:
        """A message on the command topic (the machine hands it here)."""
        if msg.sender != GROUND_STATION:
            return  # only the ground station commands
        try:
            command = cmds.decode_command(msg.body)
        except (msgspec.DecodeError, cmds.CommandError):
            self.machine.undecodable(msg, now)
            return
        self._command(command, now)

    # --- ground-station commands ---------------------------------------------------------

    def _reply(self, reply: cmds.Reply, now: float) -> None:
        self.node.send_app(GROUND_STATION, cmds.TOPIC_REPLY, cmds.encode(reply), now, urgent=True)

    def _ack(self, sha: str, now: float) -> None:
        """Confirm the script ``sha``, with when its task began if it runs here already."""
        began = self.began if self.script_sha == sha else None
        self._reply(cmds.DeployAck(sha256=sha, began=began), now)

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
        """Carry out ``command`` by its handler (:data:`_COMMAND_HANDLERS`); returns the
        message of its :class:`~actorswarm.engine.commands.Result`, or None when the handler
        answered with a reply of its own."""
        return _COMMAND_HANDLERS[type(command)](self, command, now)

    # --- one handler per command (the table _COMMAND_HANDLERS below the class) ----------

    def _cmd_start(self, command: cmds.Start, now: float) -> str:
        return self._start_script(command.sha256, now, command.began)

    def _cmd_inject(self, command: cmds.Inject, now: float) -> str:
        running = set(self.runtime.running())
        if command.actors and not running & set(command.actors):
            return f"not running {', '.join(command.actors)}: event {command.event} skipped"
        self.machine.inject(
            command.event,
            now,
            data=command.data,
            occasion=command.occasion,
            shared=not command.actors,
        )
        return f"event {command.event} delivered"

    def _cmd_force_start(self, command: cmds.ForceStart, now: float) -> str:
        self._known_actor(command.actor)
        self.runtime.start(command.actor, now, ActorContext())
        self.machine.forced("", command.actor, now)
        return f"started {command.actor}"

    def _cmd_force_stop(self, command: cmds.ForceStop, now: float) -> str:
        self.runtime.stop(command.actor, now)
        self.machine.forced(command.actor, "", now)
        return f"stopped {command.actor}"

    def _cmd_pause(self, command: cmds.Pause, now: float) -> str:
        self.runtime.pause(command.actor, now)
        self.machine.announce(now)
        return f"paused {command.actor}"

    def _cmd_activate(self, command: cmds.Activate, now: float) -> str:
        self.runtime.activate(command.actor, now)
        self.machine.announce(now)
        return f"activated {command.actor}"

    def _cmd_backup(self, command: cmds.Backup, now: float) -> None:
        snapshot = self.runtime.snapshot()
        generation = self.store.write(snapshot)
        self._reply(cmds.BackupReply(generation=generation, size=len(snapshot)), now)

    def _cmd_status(self, command: cmds.Status, now: float) -> None:
        self._reply(self._status(now), now)

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
            roles=sorted(self.node.roles.held),
            began=self.began,
            clock=None if now is None else now + self.clock_offset(),
        )

    def _deploy_chunk(self, chunk: cmds.DeployChunk, now: float) -> str | None:
        if chunk.sha256 in self._deployed:
            self._ack(chunk.sha256, now)
            return None
        if chunk.sha256 in self._checking:
            return None  # a retransmission while the check runs: the verdict answers it
        parts = self._chunks.setdefault(chunk.sha256, {})
        parts[chunk.index] = chunk.data
        if len(parts) < chunk.total:
            return None
        del self._chunks[chunk.sha256]
        text = b"".join(parts[i] for i in range(chunk.total))
        if sha256_hex(text) != chunk.sha256:
            raise ValueError("the script does not hash to the SHA-256 it was sent with")
        if self.check_later is not None:
            self._checking[chunk.sha256] = text
            self.check_later(chunk.sha256, text.decode("utf-8", errors="replace"))
            return None
        try:
            script = self.checker(
                text.decode("utf-8", errors="replace"), f"deploy:{chunk.sha256[:12]}"
            )
        except ScriptRefused as exc:
            raise ValueError(f"script refused: {exc}") from None
        self._deployed[chunk.sha256] = Plan.build(script)
        if self.on_deployed is not None:
            self.on_deployed(chunk.sha256, text)
        self._ack(chunk.sha256, now)
        return None

    def checked(self, sha: str, verdict: TaskScript | ScriptRefused, now: float) -> None:
        """The verdict of a check :attr:`check_later` ran for the deployed script ``sha``:
        the script is kept and acknowledged, or refused with the reason, as an in-line check
        would have (the outcome is recorded as a ``DeployChunk`` command)."""
        text = self._checking.pop(sha, None)
        if text is None:
            return
        if isinstance(verdict, ScriptRefused):
            self.commands.append(CommandRecord(t=now, command="DeployChunk", event="", ok=False))
            self._result("DeployChunk", False, f"script refused: {verdict}", now)
            return
        self._deployed[sha] = Plan.build(verdict)
        if self.on_deployed is not None:
            self.on_deployed(sha, text)
        self._ack(sha, now)

    def adopt(self, script: bytes) -> str:
        """Register ``script`` as deployed (a daemon restarting with the scripts of its state
        directory); returns its SHA-256. ValueError when the script is invalid."""
        sha = sha256_hex(script)
        try:
            model = self.checker(script.decode("utf-8", errors="replace"), f"kept:{sha[:12]}")
        except ScriptRefused as exc:
            raise ValueError(f"script {sha[:12]} refused: {exc}") from None
        self._deployed[sha] = Plan.build(model)
        return sha

    def rejoin(self, sha: str, now: float, *, began: float | None = None) -> bool:
        """After a restart: run the adopted script ``sha`` again, resuming the actors of the
        latest backup, or starting the initial actors when there is none (returns whether
        a backup was resumed), in the task that started at ``began`` on the shared clock
        (None: unknown, counted from now). ValueError when ``sha`` was not adopted."""
        plan = self._deployed.get(sha)
        if plan is None:
            raise ValueError(f"script {sha[:12]} is not known here; adopt it first")
        self._keep_began(began, now)
        self.script_sha = sha
        self.machine.plan = plan
        self.runtime.use_script(plan.script)
        if self.machine.resume(now):
            return True
        self.machine.start(now)
        return False

    def _start_script(self, sha: str, now: float, began: float | None = None) -> str:
        plan = self._deployed.get(sha)
        if plan is None:
            raise ValueError(f"script {sha[:12]} was not deployed to platform {self.node.platform}")
        if self.script_sha == sha:
            return f"script {sha[:12]} already running"
        fresh = not self.script_sha
        if fresh:
            # The first start sets the task's clock; a new version goes on in the same task.
            self._keep_began(began, now)
        self.script_sha = sha
        if self.on_started is not None:
            self.on_started(sha)
        self.runtime.use_script(plan.script)
        if fresh and not self.runtime.running():
            self.machine.plan = plan
            self.machine.start(now)
            return f"started script {sha[:12]}"
        # A new version while running: candidacies of the old one are void; actors the new
        # script does not know stop; a platform left with nothing starts its initial actors.
        self.machine.drop_candidacies()
        self.machine.plan = plan
        known = {a.name for a in plan.script.actors}
        for actor in list(self.runtime.loaded()):
            if actor not in known:
                self.runtime.stop(actor, now)
                self.machine.forced(actor, "", now)
        if not self.runtime.loaded():
            self.machine.start(now)
        self.machine.announce(now)
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
                self.machine.switch(
                    actor, command.to, now, "", "forced", ActorContext(params=dict(command.params))
                )
        return f"{', '.join(moved)} -> {command.to}"


#: Each operator command's handler; a test checks that every command type has one.
_COMMAND_HANDLERS: Final[dict[type[Any], Callable[[TaskEngine, Any, float], str | None]]] = {
    cmds.DeployChunk: TaskEngine._deploy_chunk,
    cmds.Start: TaskEngine._cmd_start,
    cmds.Inject: TaskEngine._cmd_inject,
    cmds.Force: TaskEngine._force,
    cmds.ForceStart: TaskEngine._cmd_force_start,
    cmds.ForceStop: TaskEngine._cmd_force_stop,
    cmds.Pause: TaskEngine._cmd_pause,
    cmds.Activate: TaskEngine._cmd_activate,
    cmds.Backup: TaskEngine._cmd_backup,
    cmds.Status: TaskEngine._cmd_status,
}


def _one_clock() -> float:
    """The offset between a host's clock and the shared clock when they are one clock."""
    return 0.0
