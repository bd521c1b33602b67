"""The operator's commands from the page, carried out through a ground station.

An :class:`Operator` turns one request of :mod:`actorswarm.web.protocol` into ground-station
commands (:class:`~actorswarm.ground.station.GroundStation`), waits for every platform's
answer and reports an :class:`Outcome`: pending while answers come in (each one published
as it arrives, so the page shows confirmations one by one), then done — ok when every
platform answered and at least one carried the command out (a deployment: when every one
confirmed the script), as ``actorswarm gs`` decides.

It does not care whether the ground station talks to a simulated radio or to Zenoh: a
:class:`Driver` runs an action on the station and sends what it produced, and the owner
hands every reply over (:meth:`Operator.on_reply`) from wherever it reads them. Commands
run one at a time: a reply says which kind of command it answers but not which instance,
so two of a kind in flight could not be told apart.
"""

from __future__ import annotations

import asyncio
import contextlib
import hashlib
import time
from collections import Counter
from collections.abc import Callable, Collection
from dataclasses import dataclass, field
from typing import Any, Final, Literal, Protocol, TypeVar

from actorswarm.dsl.checker import check
from actorswarm.dsl.model import TaskScript
from actorswarm.dsl.syntax import platform_ids
from actorswarm.engine import commands as cmds
from actorswarm.ground.station import GroundStation, NotConfirmed, ReplyRecord
from actorswarm.web import protocol as proto

__all__ = ["PAGE_COMMANDS", "Driver", "Operator", "Outcome", "Timeouts"]

_T = TypeVar("_T")

#: Least wall seconds between two progress reports of one command.
PROGRESS = 0.2


class Driver(Protocol):
    """How the operator reaches its ground station."""

    @property
    def station(self) -> GroundStation: ...

    def act(self, action: Callable[[GroundStation, float], _T]) -> _T:
        """Run ``action(station, now)`` now and send what it produced."""
        ...


@dataclass(frozen=True, slots=True)
class Timeouts:
    """Wall-clock seconds to wait for every platform's answer."""

    deploy: float = 10.0
    command: float = 5.0


@dataclass(slots=True)
class Outcome:
    """What became of one request: published while pending and once done."""

    id: str
    op: str
    asked: str
    t: float
    state: Literal["pending", "done"] = "pending"
    ok: bool | None = None
    message: str = ""
    targets: list[int] = field(default_factory=list)
    answers: dict[int, tuple[bool, str]] = field(default_factory=dict)
    #: A script's problems: ``{"line", "col", "message", "severity"}``.
    diagnostics: list[dict[str, Any]] = field(default_factory=list)

    def finish(self, ok: bool, message: str) -> Outcome:
        self.state, self.ok, self.message = "done", ok, message
        return self

    def to_json(self) -> dict[str, Any]:
        return {
            "type": "outcome",
            "id": self.id,
            "op": self.op,
            "asked": self.asked,
            "t": round(self.t, 3),
            "state": self.state,
            "ok": self.ok,
            "message": self.message,
            "targets": self.targets,
            "answers": {str(p): {"ok": ok, "message": m} for p, (ok, m) in self.answers.items()},
            "diagnostics": self.diagnostics,
        }


#: Picks, from a reply, the ``(ok, message)`` it gives the command waited for (or None).
Match = Callable[[cmds.Reply], tuple[bool, str] | None]


@dataclass(slots=True)
class _Waiting:
    outcome: Outcome
    match: Match
    done: asyncio.Event = field(default_factory=asyncio.Event)
    published: float = 0.0


def _result_of(name: str) -> Match:
    def match(reply: cmds.Reply) -> tuple[bool, str] | None:
        return cmds.outcome(reply, name)

    return match


def _confirmation_of(sha: str) -> Match:
    def match(reply: cmds.Reply) -> tuple[bool, str] | None:
        if isinstance(reply, cmds.DeployAck) and reply.sha256 == sha:
            return True, f"confirmed {sha[:12]}"
        if isinstance(reply, cmds.Result) and reply.command == "DeployChunk" and not reply.ok:
            return False, reply.message
        return None

    return match


def _summary(outcome: Outcome) -> str:
    """``8 of 10: event x delivered; 2 of 10: ...; no answer from [9, 10]``."""
    n = len(outcome.targets)
    said = Counter(
        m if ok else f"FAILED: {m}"
        for p, (ok, m) in outcome.answers.items()
        if p in outcome.targets
    )
    parts = [f"{k} of {n}: {m}" for m, k in said.most_common()]
    missing = sorted(set(outcome.targets) - set(outcome.answers))
    if missing:
        parts.append(f"no answer from {missing}")
    return "; ".join(parts) or "no answer"


class Operator:
    """Carries out requests through ``driver`` (see the module docstring).

    ``heard()`` lists the platforms a request without a platform list goes to;
    ``publish(outcome)`` is called on every change of an outcome; ``on_started(script)``
    when a script deployed from the page was started by at least one platform. ``areas()``
    names the areas of the world the swarm flies in (None: no world known): a script
    checked or deployed from the page must name only those, as ``actorswarm task check
    --world`` demands, or it is refused before anything is sent.
    """

    def __init__(
        self,
        driver: Driver,
        *,
        now: Callable[[], float],
        heard: Callable[[], list[int]],
        publish: Callable[[Outcome], None],
        on_started: Callable[[TaskScript, str], None] | None = None,
        timeouts: Timeouts | None = None,
        areas: Callable[[], Collection[str] | None] | None = None,
    ) -> None:
        self.driver = driver
        self.now = now
        self.heard = heard
        self.publish = publish
        self.on_started = on_started
        self.timeouts = timeouts or Timeouts()
        self.areas = areas or (lambda: None)
        self.scripts: dict[str, TaskScript] = {}
        self._lock = asyncio.Lock()
        self._waiting: _Waiting | None = None

    def on_reply(self, record: ReplyRecord) -> None:
        """A platform's reply, handed over by the owner of the ground station."""
        waiting = self._waiting
        if waiting is None or record.platform not in waiting.outcome.targets:
            return
        said = waiting.match(record.reply)
        if said is None:
            return
        outcome = waiting.outcome
        outcome.answers[record.platform] = said
        if set(outcome.targets) <= set(outcome.answers):
            waiting.done.set()  # the final outcome is published by execute()
            return
        # Progress at most every PROGRESS seconds: an outcome carries every answer so far,
        # and 200 platforms answering one by one would send 200 growing copies.
        wall = time.monotonic()
        if wall - waiting.published >= PROGRESS:
            waiting.published = wall
            outcome.message = _summary(outcome)
            self.publish(outcome)

    async def execute(self, request: proto.Command) -> Outcome:
        """Carry out ``request`` (not :class:`~actorswarm.web.protocol.Speed`: the source
        does that); returns the final outcome, which was published too."""
        op = str(request.__struct_config__.tag)  # as the page wrote it: "stop_actor"
        outcome = Outcome(id=request.id, op=op, asked="", t=self.now())
        try:
            outcome = await self._execute(request, outcome)
        except ValueError as exc:  # a bad platform list, an impossible start
            outcome.finish(False, str(exc))
        self.publish(outcome)
        return outcome

    async def _execute(self, request: proto.Command, outcome: Outcome) -> Outcome:
        if isinstance(request, proto.Check):
            outcome.asked = f"check {request.name}"
            return self._checked(request.script, request.name, outcome)[1]
        if isinstance(request, proto.Deploy):
            return await self._deploy(request, outcome)
        async with self._lock:
            if isinstance(request, proto.Start):
                return await self._start(request.force, outcome)
            name, command, asked = self._command(request)
            outcome.asked = asked
            targets = self._targets(getattr(request, "platforms", None))
            return await self._run(
                outcome, targets, _result_of(name), self.timeouts.command, command
            )

    @staticmethod
    def _command(request: proto.Command) -> tuple[str, cmds.Command, str]:
        """The ground-station command of ``request``: (reply name, command, description),
        by the one table :data:`PAGE_COMMANDS`."""
        make = PAGE_COMMANDS.get(type(request))
        if make is None:
            raise ValueError(f"{type(request).__name__} is not a ground-station command")
        command, asked = make(request)
        return type(command).__name__, command, asked

    def _targets(self, platforms: str | None) -> list[int]:
        if platforms is None or not platforms.strip():
            targets = self.heard()
            if not targets:
                raise ValueError("no platform heard: nobody to send it to")
            return targets
        try:
            return sorted(platform_ids(platforms))
        except ValueError as exc:
            raise ValueError(f"platforms: {exc}") from None

    async def _run(
        self,
        outcome: Outcome,
        targets: list[int],
        match: Match,
        timeout: float,
        command: cmds.Command | None = None,
    ) -> Outcome:
        """Send ``command`` (None: already sent) to ``targets`` and wait up to ``timeout``
        seconds for their answers."""
        outcome.targets = targets
        outcome.asked += f" to {_ids(targets)}"
        waiting = _Waiting(outcome, match)
        self._waiting = waiting
        self.publish(outcome)
        try:
            if command is not None:
                self.driver.act(lambda st, now: self._send(st, command, targets, now))
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(waiting.done.wait(), timeout)
        finally:
            self._waiting = None
        answered = [ok for p, (ok, _) in outcome.answers.items() if p in targets]
        complete = len(answered) == len(targets)
        return outcome.finish(complete and any(answered), _summary(outcome))

    @staticmethod
    def _send(st: GroundStation, command: cmds.Command, targets: list[int], now: float) -> None:
        if isinstance(command, cmds.Inject):
            # GroundStation.event numbers the occasion, so platforms that hear the event
            # twice (from the station and relayed by the master) act on it once.
            st.event(command.event, now, platforms=targets, actors=command.actors)
        else:
            st.send(command, targets, now)

    def _checked(self, text: str, name: str, outcome: Outcome) -> tuple[TaskScript | None, Outcome]:
        result = check(text, path=name, areas=self.areas())
        outcome.diagnostics = [
            {"line": d.line, "col": d.col, "message": d.message, "severity": d.severity}
            for d in result.diagnostics
        ]
        if result.script is None or not result.ok:
            errors = [d for d in result.diagnostics if d.severity == "error"]
            first = errors[0] if errors else None
            where = f"; first at line {first.line}, column {first.col}" if first else ""
            return None, outcome.finish(False, f"{len(errors)} error(s) in {name}{where}")
        warned = len(result.diagnostics)
        return result.script, outcome.finish(
            True, f"{name} is valid" + (f" ({warned} warning(s))" if warned else "")
        )

    async def _deploy(self, request: proto.Deploy, outcome: Outcome) -> Outcome:
        outcome.asked = f"deploy {request.name}"
        script, outcome = self._checked(request.script, request.name, outcome)
        if script is None:
            return outcome
        outcome.state, outcome.ok = "pending", None
        data = request.script.encode("utf-8")
        sha = hashlib.sha256(data).hexdigest()
        async with self._lock:
            targets = self._targets(request.platforms)
            self.scripts[sha] = script
            outcome.asked = f"deploy {request.name} ({sha[:12]})"
            self.driver.act(lambda st, now: st.deploy(data, targets, now))
            outcome = await self._run(outcome, targets, _confirmation_of(sha), self.timeouts.deploy)
        confirmed = all(ok for p, (ok, _) in outcome.answers.items() if p in targets)
        return outcome.finish(bool(outcome.ok) and confirmed, outcome.message)

    async def _start(self, force: bool, outcome: Outcome) -> Outcome:
        station = self.driver.station
        sha = station.deployed_sha
        outcome.asked = "start" + (" (forced)" if force else "")
        if not sha:
            return outcome.finish(False, "nothing deployed from this page: deploy a script first")
        try:
            self.driver.act(lambda st, now: st.start(now, force=force, began=time.time()))
        except NotConfirmed as exc:
            return outcome.finish(False, str(exc))
        outcome.asked = f"start {sha[:12]}" + (" (forced)" if force else "")
        targets = sorted(station.expected.get(sha, set()))
        outcome = await self._run(outcome, targets, _result_of("Start"), self.timeouts.command)
        script = self.scripts.get(sha)
        if (
            script is not None
            and self.on_started is not None
            and any(ok for ok, _ in outcome.answers.values())
        ):
            self.on_started(script, sha)
        return outcome


def _ids(targets: list[int]) -> str:
    from actorswarm.dsl.syntax import id_ranges

    if not targets:
        return "nobody"
    return f"platform{'s' if len(targets) > 1 else ''} {id_ranges(frozenset(targets))}"


def _event(request: proto.Event) -> tuple[cmds.Command, str]:
    only = f" (holders of {', '.join(request.actors)})" if request.actors else ""
    # The occasion is set by the sender, as GroundStation.event does.
    return cmds.Inject(event=request.name, actors=request.actors), f"event {request.name}{only}"


def _force(request: proto.Force) -> tuple[cmds.Command, str]:
    command = cmds.Force(to=request.to, src=request.src, params=request.params)
    return command, f"force {request.src or 'any actor'} -> {request.to}"


#: The page's requests that are ground-station commands, each mapped onto the command the
#: platforms carry out (:mod:`actorswarm.engine.commands`) and the words that describe it;
#: the reply to expect is named by the command's type.
PAGE_COMMANDS: Final[dict[type[Any], Callable[[Any], tuple[cmds.Command, str]]]] = {
    proto.Event: _event,
    proto.Force: _force,
    proto.Pause: lambda r: (cmds.Pause(actor=r.actor), f"pause {r.actor}"),
    proto.Activate: lambda r: (cmds.Activate(actor=r.actor), f"activate {r.actor}"),
    proto.StartActor: lambda r: (cmds.ForceStart(actor=r.actor), f"start {r.actor}"),
    proto.StopActor: lambda r: (cmds.ForceStop(actor=r.actor), f"stop {r.actor}"),
    proto.Backup: lambda r: (cmds.Backup(), "backup"),
}
