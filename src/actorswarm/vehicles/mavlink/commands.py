"""Commands to the autopilot: ``COMMAND_LONG`` retried until ``COMMAND_ACK``, in steps.

The MAVLink command protocol: the sender repeats a command (the ``confirmation`` field
counting the repeats) until the autopilot answers with a ``COMMAND_ACK`` for it. An ack
``ACCEPTED`` ends the step, ``IN_PROGRESS`` stops the repeats while the autopilot works,
``TEMPORARILY_REJECTED`` ("try again later") lets them go on, anything else is a refusal.
Nothing is retried for ever: a step not accepted within its
deadline fails.

A :class:`Command` marked ``persist`` (arming) is one the autopilot refuses while it is not
ready yet: any refusal (``FAILED``, ``DENIED``, ``TEMPORARILY_REJECTED``...) is asked again
after a back-off (1 s, doubling up to 4 s) until the step's deadline, and each refusal is
reported to ``on_refused``. A persisting command may have a ``gate`` (the autopilot's
readiness signals): while the gate says "not yet" the command is still sent, but only every
``probe`` seconds, and at once when the gate opens — advice that paces the asking, never a
lock, so a signal that never comes cannot keep the autopilot from being asked. A step's
``deadline`` may count from the start of the whole plan (``from_plan``): the arming
retries then end at the vehicle's ``arm_timeout`` of the take-off. ``explain`` adds the
autopilot's own words to a failure.

One plan of the vehicle (take off: set the mode, check the failsafes, arm, take off) is a
:class:`Sequence` of steps run in order — a :class:`Command`, a :class:`Check` that waits for
a fact about the autopilot (its failsafe parameters known and set), or a :class:`Do` that
runs at once (start streaming setpoints). A step that fails abandons the rest of its
sequence and leaves an error naming the vehicle, the plan and the command in
:meth:`CommandSender.drain_errors`. A new sequence replaces the one in progress, as a new
command to a :class:`~actorswarm.runtime.context.Vehicle` replaces its previous goal.

No clock and no socket: the owner gives ``now``, passes each ``COMMAND_ACK`` in, and the
sender hands the messages to send to its ``send`` callable.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from actorswarm.vehicles.mavlink.dialect import command_name, mav, result_name

__all__ = ["Check", "Command", "CommandSender", "Do", "Step"]

#: The answer of a :class:`Check`: True (go on), None (not known yet: ask again), or the
#: reason it fails.
CheckResult = bool | str | None


@dataclass(frozen=True, slots=True)
class Command:
    """One ``COMMAND_LONG``: ``command`` (a ``MAV_CMD``) with its seven parameters."""

    command: int
    params: tuple[float, float, float, float, float, float, float] = (0, 0, 0, 0, 0, 0, 0)
    #: Ask again after any refusal, with back-off, until the deadline.
    persist: bool = False
    #: Seconds (None: the sender's), counted from the plan's start with ``from_plan``.
    deadline: float | None = None
    from_plan: bool = False
    #: A persisting command: True when it is worth asking now; otherwise it is asked only
    #: every ``probe`` seconds (None: no gate).
    gate: Callable[[], bool | None] | None = None
    probe: float = 10.0

    @property
    def name(self) -> str:
        return command_name(self.command)


@dataclass(frozen=True, slots=True)
class Check:
    """Wait until ``test()`` says True; a string from it is the reason the plan stops.
    ``deadline`` (seconds) replaces the sender's for this step (a climb takes longer than
    an answer)."""

    name: str
    test: Callable[[], CheckResult]
    deadline: float | None = None
    from_plan: bool = False


@dataclass(frozen=True, slots=True)
class Do:
    """Run ``action()`` when the sequence reaches it, then go on."""

    name: str
    action: Callable[[], None]


Step = Command | Check | Do


@dataclass(slots=True)
class _Running:
    label: str
    steps: list[Step]
    began: float = 0.0  # when the plan began
    started: float = 0.0  # when the current step began
    sent: float | None = None  # when the current command was last sent
    tries: int = 0
    working: bool = False  # the autopilot said IN_PROGRESS
    rejected: bool = False  # the autopilot said TEMPORARILY_REJECTED
    backoff: float = 0.0  # a persisting command: seconds to wait before asking again
    refused: str | None = None  # a persisting command: the last refusal
    answered: bool = False  # a persisting command: the last try was answered
    gated: bool = False  # a gated command: its gate was closed at the last look
    done: list[str] = field(default_factory=list)


class CommandSender:
    """Runs one sequence of steps at a time for the vehicle named ``vehicle``, whose
    autopilot is ``target`` = (system ID, component ID).

    ``retry``: seconds between two sendings of an unanswered command; ``deadline``:
    seconds a step may take (an answered ``IN_PROGRESS`` included) before it fails.
    """

    def __init__(
        self,
        vehicle: str,
        send: Callable[[Any], None],
        target: tuple[int, int],
        *,
        retry: float = 0.5,
        deadline: float = 5.0,
        explain: Callable[[], str | None] = lambda: None,
        on_refused: Callable[[str, int], None] = lambda name, result: None,
    ) -> None:
        if not (retry > 0 and deadline > 0):
            raise ValueError(f"retry and deadline must be > 0 s, not {retry!r}, {deadline!r}")
        self.vehicle = vehicle
        self.target = target
        self.retry = retry
        self.deadline = deadline
        self._send = send
        self._explain = explain
        self._on_refused = on_refused
        self._running: _Running | None = None
        self._errors: list[str] = []
        #: Plans that ran to their end, in order (for status and tests).
        self.completed: list[str] = []

    @property
    def busy(self) -> str | None:
        """The label of the sequence in progress (None: idle)."""
        return None if self._running is None else self._running.label

    @property
    def step(self) -> Step | None:
        """The step in progress (None: idle)."""
        run = self._running
        return run.steps[0] if run is not None and run.steps else None

    @property
    def began(self) -> float | None:
        """When the plan in progress began (None: idle)."""
        return None if self._running is None else self._running.began

    def start(self, label: str, steps: Sequence[Step], now: float) -> None:
        """Run ``steps`` as the plan ``label`` from ``now``, abandoning any plan in progress;
        the first command goes out at once."""
        self._running = _Running(label, list(steps), began=now, started=now)
        self.tick(now)

    def cancel(self) -> None:
        """Abandon the plan in progress, quietly."""
        self._running = None

    def drain_errors(self) -> list[str]:
        """The failures since the last call, oldest first."""
        out, self._errors = self._errors, []
        return out

    def on_ack(self, ack: Any, now: float) -> None:
        """A ``COMMAND_ACK`` from the autopilot (already filtered to this vehicle's)."""
        run = self._running
        if run is None or not run.steps:
            return
        step = run.steps[0]
        if not isinstance(step, Command) or ack.command != step.command:
            return  # an answer to something else (an earlier plan, another sender)
        if ack.result == mav.MAV_RESULT_ACCEPTED:
            self._advance(run, now)
            self.tick(now)
        elif step.persist and ack.result != mav.MAV_RESULT_IN_PROGRESS:
            # Not ready yet: ask again later, until the deadline.
            if run.answered:
                return  # a second answer to the same try (a repeat crossed its answer)
            run.answered = True
            run.refused = result_name(ack.result)
            run.working = False
            run.sent = now
            run.backoff = min(max(run.backoff * 2, 1.0), 4.0)
            self._on_refused(step.name, ack.result)
        elif ack.result == mav.MAV_RESULT_IN_PROGRESS:
            run.working = True
        elif ack.result == mav.MAV_RESULT_TEMPORARILY_REJECTED:
            run.working = False  # "try again later": the repeats go on until the deadline
            run.rejected = True
        else:
            self._on_refused(step.name, ack.result)
            reason = self._explain()
            self._fail(
                run,
                f"{step.name} refused by the autopilot: {result_name(ack.result)}"
                + (f" — {reason}" if reason else ""),
            )

    def tick(self, now: float) -> None:
        """Move the plan on at ``now``: run the steps that need no answer, send or resend
        the current command, fail a step past its deadline."""
        run = self._running
        while run is not None and run is self._running and run.steps:
            step = run.steps[0]
            limit = step.deadline if not isinstance(step, Do) and step.deadline else self.deadline
            since = run.began if not isinstance(step, Do) and step.from_plan else run.started
            if now - since > limit:
                what = step.name if isinstance(step, Command) else f"waiting for {step.name}"
                plural = "try" if run.tries == 1 else "tries"
                tries = f" ({run.tries} {plural})" if isinstance(step, Command) else ""
                if run.refused is not None:
                    tries += f", last refused: {run.refused}"
                elif run.rejected:
                    tries += ", temporarily rejected"
                reason = self._explain()
                self._fail(
                    run,
                    f"{what}: not done within {limit:g} s{tries}"
                    + (f" — {reason}" if reason else ""),
                )
                return
            if isinstance(step, Do):
                step.action()
                self._advance(run, now)
            elif isinstance(step, Check):
                verdict = step.test()
                if verdict is True:
                    self._advance(run, now)
                elif isinstance(verdict, str):
                    self._fail(run, f"{step.name}: {verdict}")
                    return
                else:
                    return
            else:
                wait = run.backoff if run.backoff else self.retry
                if step.gate is not None:
                    opened = step.gate() is True
                    if not opened:
                        wait = max(wait, step.probe)
                    elif run.gated:
                        wait = 0.0  # the gate just opened: ask at once
                    run.gated = not opened
                if not run.working and (run.sent is None or now - run.sent >= wait):
                    self._send_command(run, step, now)
                return
        if run is not None and run is self._running and not run.steps:
            self._finish(run)

    def _send_command(self, run: _Running, step: Command, now: float) -> None:
        system, component = self.target
        # ``confirmation`` counts the repeats, as the protocol asks (0 the first time).
        message = mav.MAVLink_command_long_message(
            system, component, step.command, min(run.tries, 255), *step.params
        )
        run.tries += 1
        run.sent = now
        run.answered = False
        self._send(message)

    def _advance(self, run: _Running, now: float) -> None:
        step = run.steps.pop(0)
        run.done.append(step.name)
        run.started, run.sent, run.tries = now, None, 0
        run.working = run.rejected = False
        run.backoff, run.refused, run.gated = 0.0, None, False
        if not run.steps:
            self._finish(run)

    def _finish(self, run: _Running) -> None:
        if run is self._running:
            self._running = None
            self.completed.append(run.label)

    def _fail(self, run: _Running, why: str) -> None:
        self._errors.append(f"vehicle {self.vehicle}: {run.label}: {why}")
        if run is self._running:
            self._running = None
