"""The detection and tracking plugins (docs/design.md §6): see a target, claim it, follow it.

``detect.target`` (:class:`DetectTarget`)
    Watches the camera for a target (of a kind, by name, or any). Writes the nearest one
    it sees to ``ctx.blackboard["target"]`` on every step, and emits ``event``
    (``target_detected_event``) once — after winning the target's tracker role from the
    swarm, unless ``exclusive`` is off.
``track.target`` (:class:`TrackTarget`)
    The paper's *Track* actor: flies over the target at ``altitude`` and keeps there,
    chasing it as it moves; emits ``lost_event`` (when given) when it has not been seen
    for ``lost_after`` seconds.

Theory of operation
-------------------
**One tracker per target.** A searcher that sees the jeep should switch to tracking it,
but several searchers may see it at once, and a task script can only say ``sysNum="1"``
per platform's event, not per target. So the detector arbitrates through the collective
core's roles (docs/design.md §3.4): the target named ``jeep`` has the role ``track:jeep`` with a
quota of 1 (:func:`track_role`). In exclusive mode :class:`DetectTarget` claims that role
when it first sees the target and emits its event only once the master's answer
(``ctx.blackboard["collective"]``, :func:`actorswarm.runtime.collective.plugin_view`) says
``granted``; on ``denied`` it releases the claim — so it does not wait in the master's
queue and win the role later, when it may no longer see the target — and asks again
``retry`` seconds later if it still sees it. The winner keeps the role after its event:
it is the tracker. :class:`TrackTarget` claims the same role when it starts (an idempotent
re-claim on the platform that won it; a claim that keeps detectors quiet on a platform
switched in some other way) and releases it when it stops, so another platform may take
the target over.

**Taking over from a lost tracker.** A tracker promoted by ``X_lost`` was not told which
target to follow, but the event's data lists the roles the lost platform held
(:mod:`actorswarm.engine.promotion`): :class:`TrackTarget` locks on the target of the lost
``track:<name>`` and claims that role at once, before it has seen the target, so that a
searcher that sees it meanwhile is denied the role and keeps searching; it looks first
where the lost tracker last was (it flew over the target), then sweeps its ``area``. Should two
platforms still both track one target — a searcher won the role before the promoted
tracker claimed it, or a platform taken for lost comes back still tracking — the master
grants the role to one only: the other is denied (or, after a partition heals, revoked),
and :class:`TrackTarget` emits its ``yield_event``, on which the script sends it back to
searching. One tracker per target remains.

**Where the target is**, for the tracker, in order: the nearest matching detection of its
own camera now; else the last position it knows — its own last sighting, or a newer
``ctx.blackboard["target"]`` (written by a :class:`DetectTarget` in the same actor), or
the position the switching transition brought (``ctx.data`` holding ``x`` and ``y``, or
``ctx.data["event"]`` doing so). With nothing known it holds where it is and waits. The
target's velocity is estimated from successive sightings; the tracker asks the vehicle for
the target's speed plus what closes the gap in :data:`CATCH_UP_TIME` seconds, and, like
the formation plugins, re-sends the point only when it moved at least
:data:`~actorswarm.plugins.formation.RECOMMAND_DISTANCE`.

Once the tracker locks on a name (its ``target`` param, the name the transition or the
blackboard brought, or the first target it sees) it keeps to that name, so two targets
crossing do not swap its attention.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, ClassVar, Final

from actorswarm.plugins.formation import RECOMMAND_DISTANCE
from actorswarm.plugins.search import LANE_PER_ALTITUDE, lanes, parse_area
from actorswarm.plugins.snapshot import TaskTime, finite, read_flag, read_point, read_time
from actorswarm.runtime.builtin import EVENT_NAME_FORM, EVENT_NAME_PATTERN
from actorswarm.runtime.context import CollectiveUnavailable
from actorswarm.runtime.plugin import Param, Plugin, Point

if TYPE_CHECKING:
    from actorswarm.runtime.context import Detection, PluginContext

#: How close to a sweep waypoint (metres) counts as reached.
_SWEEP_TOLERANCE: Final = 3.0

__all__ = ["CATCH_UP_TIME", "UNSEEN_BID", "DetectTarget", "TrackTarget", "track_role"]

#: The tracker's commanded speed closes its gap to the target in about this many seconds,
#: on top of the target's own speed.
CATCH_UP_TIME: Final = 3.0
#: The role bid of a tracker that has not seen its target yet: behind any that has.
UNSEEN_BID: Final = 1e9
#: The least speed (m/s) the tracker asks for, so a goto near a still target still moves.
_MIN_SPEED: Final = 1.0


def track_role(name: str) -> str:
    """The collective role a platform holds while it is the tracker of target ``name``."""
    return f"track:{name}"


def _filter_params() -> dict[str, Param]:
    return {
        "kind": Param(kind="str", doc="only targets of this kind; left out: any kind"),
        "target": Param(kind="str", doc="only the target of this name; left out: any target"),
    }


def _matching(ctx: PluginContext, name: str | None = None) -> list[Detection]:
    """The camera's detections that pass the ``kind``/``target`` params (and are called
    ``name``, when given), nearest first; none without a camera."""
    camera = ctx.camera
    if camera is None:
        return []
    kind, target = ctx.params["kind"], ctx.params["target"]
    want = name if name is not None else target
    return [
        d
        for d in camera.detections()
        if (kind is None or d.kind == kind) and (want is None or d.name == want)
    ]


def _role_state(ctx: PluginContext, role: str, cursor: int) -> tuple[str | None, int]:
    """The latest answer about ``role`` on the blackboard's ``collective`` list from index
    ``cursor`` on (None: none), and the index to read from next time."""
    answers = ctx.blackboard.get("collective")
    if not isinstance(answers, list):
        return None, 0
    if len(answers) < cursor:  # someone trimmed the list
        cursor = 0
    state: str | None = None
    for answer in answers[cursor:]:
        if (
            isinstance(answer, Mapping)
            and answer.get("kind") == "role"
            and answer.get("role") == role
        ):
            value = answer.get("state")
            state = value if isinstance(value, str) else state
    return state, len(answers)


def _answers_so_far(ctx: PluginContext) -> int:
    """How many answers the blackboard's ``collective`` list holds now."""
    answers = ctx.blackboard.get("collective")
    return len(answers) if isinstance(answers, list) else 0


def _lost_tracker(ctx: PluginContext) -> tuple[str, Point | None] | None:
    """The target a lost tracker was following and where that tracker last was, when this
    actor was started by its ``X_lost``: the event's data (``ctx.data["event"]``) lists the
    roles the lost platform held and its last position ``at``
    (:func:`actorswarm.engine.promotion.lost_data`); ``track:<name>`` among the roles names
    the target. None when there is no such role (or it names another target than the
    ``target`` param)."""
    event = ctx.data.get("event") if isinstance(ctx.data, Mapping) else None
    if not isinstance(event, Mapping):
        return None
    roles, at = event.get("roles"), event.get("at")
    if not isinstance(roles, list):
        return None
    where: Point | None = None
    if isinstance(at, list) and len(at) == 3 and all(finite(v) for v in at):
        where = (float(at[0]), float(at[1]), float(at[2]))
    prefix = track_role("")
    want = ctx.params["target"]
    for role in roles:
        if isinstance(role, str) and role.startswith(prefix) and len(role) > len(prefix):
            name = role[len(prefix) :]
            if want is None or name == want:
                return name, where
    return None


def _xyz(value: object) -> Point | None:
    """``value``'s ``x``, ``y`` (and ``z``, default 0) when it is a dict holding finite
    numbers there; None otherwise."""
    if not isinstance(value, Mapping):
        return None
    x, y, z = value.get("x"), value.get("y"), value.get("z", 0.0)
    if not (finite(x) and finite(y) and finite(z)):
        return None
    assert isinstance(x, int | float) and isinstance(y, int | float) and isinstance(z, int | float)
    return (float(x), float(y), float(z))


class DetectTarget(Plugin):
    """``detect.target``: watch the camera for a target; emit ``event`` once on seeing it.

    Params:

    ``kind`` (optional)
        Only targets of this kind (``jeep``); left out: any kind.
    ``target`` (optional)
        Only the target of this name; left out: any target.
    ``event`` (default ``target_detected_event``)
        Emitted at most once per start, when a matching target is in view (and, with
        ``exclusive``, its tracker role was granted), with ``bid`` = the target's distance
        from the camera (the nearest platform wins a place) and ``data`` = ``{"target":
        name, "x", "y", "z"}`` (where it is).
    ``scope`` (``local``, the default, or ``swarm``)
        The event's scope.
    ``exclusive`` (bool, default true)
        Emit only after winning the role ``track:<name>`` (quota 1) from the swarm, so that
        two platforms never both become trackers of one target (module docstring). This
        needs the swarm behind ``ctx.collective``: a step that tries to claim without one
        raises :class:`~actorswarm.runtime.context.CollectiveUnavailable`. Give false when
        any number of platforms may react to one target, or in a test without a swarm.
    ``retry`` (float > 0, default 5)
        Seconds after a denied claim (or a claim the master has not answered) before
        claiming again, if a matching target is still in view then.

    On every step the nearest matching detection, if any, is written to
    ``ctx.blackboard["target"]`` as ``{"name", "kind", "x", "y", "z", "t"}`` (``t`` is
    ``ctx.now``), for the actor's other plugins; when nothing matches the entry keeps the
    last sighting. The camera is required: starting without one raises
    :class:`~actorswarm.runtime.context.CameraUnavailable`. The snapshot is
    ``{"fired": bool}``; a restored instance that has not fired starts its claim over. A
    pause or stop while a claim awaits its answer releases the claim.
    """

    bus = "observe_bus"
    needs_vehicle = False
    params: ClassVar[Mapping[str, Param]] = {
        **_filter_params(),
        "event": Param(
            kind="str",
            default="target_detected_event",
            pattern=EVENT_NAME_PATTERN,
            form=EVENT_NAME_FORM,
            doc="the event to emit, once, when a matching target is seen (and claimed)",
        ),
        "scope": Param(
            kind="str",
            default="local",
            choices=("local", "swarm"),
            doc="local: only this platform becomes a candidate for the event's transition; "
            "swarm: every platform whose actor has one",
        ),
        "exclusive": Param(
            kind="bool",
            default=True,
            doc="emit only after winning the target's tracker role (quota 1) from the swarm",
        ),
        "retry": Param(
            kind="float",
            default=5.0,
            minimum=0.0,
            doc="seconds after a denied or unanswered claim before claiming again (> 0)",
        ),
    }

    def __init__(self) -> None:
        self._fired = False
        self._claim: str | None = None  # the role asked for, while waiting for the answer
        self._cursor = 0  # answers on the blackboard before this index are not this claim's
        self._wait_until: float | None = None  # no claim before this time

    @property
    def fired(self) -> bool:
        """Whether the event went out in this start."""
        return self._fired

    def on_start(self, ctx: PluginContext) -> None:
        retry = float(ctx.params["retry"])
        if retry <= 0:
            raise ValueError(f"detect.target: retry must be > 0 seconds, not {retry:g}")
        ctx.require_camera()
        self._fired, self._claim, self._wait_until = False, None, None

    def step(self, ctx: PluginContext) -> None:
        ctx.require_camera()
        seen = _matching(ctx)
        if seen:
            nearest = seen[0]
            x, y, z = nearest.position
            ctx.blackboard["target"] = {
                "name": nearest.name,
                "kind": nearest.kind,
                "x": x,
                "y": y,
                "z": z,
                "t": ctx.now,
            }
        if self._fired:
            return
        if self._claim is not None:
            self._await_answer(ctx, seen)
            if self._fired or self._claim is not None:
                return
        if self._wait_until is not None:
            if ctx.now < self._wait_until:
                return
            self._wait_until = None  # a deadline in the past would wake the host at once
        if not seen:
            return
        if not ctx.params["exclusive"]:
            self._fire(ctx, seen[0])
            return
        role = track_role(seen[0].name)
        before = _answers_so_far(ctx)
        try:
            ctx.collective.claim_role(role, 1, bid=seen[0].distance)
        except CollectiveUnavailable as exc:
            raise CollectiveUnavailable(
                f"detect.target: with exclusive true it claims the role {role!r} from the "
                f"swarm before emitting, and there is no swarm here ({exc}); give "
                "exclusive=false to emit without claiming"
            ) from exc
        self._cursor, self._claim = before, role
        self._wait_until = ctx.now + float(ctx.params["retry"])

    def _await_answer(self, ctx: PluginContext, seen: list[Detection]) -> None:
        assert self._claim is not None
        role = self._claim
        state = self._answer(ctx, role)
        if state == "granted":
            self._claim = None
            mine = [d for d in seen if track_role(d.name) == role]
            if mine:
                self._fire(ctx, mine[0])
                return
            # Granted a target no longer in view: it is not this platform's to track.
            ctx.collective.release_role(role)
            self._wait_until = ctx.now + float(ctx.params["retry"])
        elif state in ("denied", "revoked"):
            self._claim = None
            ctx.collective.release_role(role)
            self._wait_until = ctx.now + float(ctx.params["retry"])
        elif self._wait_until is not None and ctx.now >= self._wait_until:
            # No answer (a master change may have lost the claim): ask again.
            self._claim, self._wait_until = None, None

    def _answer(self, ctx: PluginContext, role: str) -> str | None:
        """The latest answer about ``role`` since the claim, or None."""
        state, self._cursor = _role_state(ctx, role, self._cursor)
        return state

    def _fire(self, ctx: PluginContext, detection: Detection) -> None:
        x, y, z = detection.position
        self._fired = True
        ctx.emit(
            ctx.params["event"],
            scope=ctx.params["scope"],
            bid=detection.distance,
            data={"target": detection.name, "x": x, "y": y, "z": z},
        )

    def on_pause(self, ctx: PluginContext) -> None:
        self._withdraw(ctx)

    def on_activate(self, ctx: PluginContext) -> None:
        ctx.require_camera()
        self._claim, self._wait_until = None, None

    def on_stop(self, ctx: PluginContext) -> None:
        self._withdraw(ctx)

    def _withdraw(self, ctx: PluginContext) -> None:
        """Release a claim still waiting for its answer: a grant arriving while the
        detector is asleep or gone would make this platform the target's tracker for
        nothing. (A claim that led to the event is kept: the tracker holds it.)"""
        if self._claim is not None:
            with contextlib.suppress(CollectiveUnavailable):
                ctx.collective.release_role(self._claim)
            self._claim = None

    def next_deadline(self) -> float | None:
        return None if self._fired else self._wait_until

    def snapshot(self) -> dict[str, Any]:
        return {"fired": self._fired}

    def restore(self, state: Mapping[str, Any]) -> None:
        self._fired = read_flag("detect.target", state, "fired")


class TrackTarget(Plugin):
    """``track.target``: fly over the target at ``altitude`` and keep there as it moves.

    Params:

    ``altitude`` (float > 0, default 20)
        Metres above the ground to follow the target at.
    ``kind`` (optional)
        Only targets of this kind; left out: any kind.
    ``target`` (optional)
        Only the target of this name; left out: the one the switching transition or the
        blackboard names, else the first seen.
    ``lost_after`` (float > 0, default 10)
        Seconds without a sighting after which the target counts as lost.
    ``lost_event`` (optional)
        Emitted, scope local, when the target becomes lost (once per loss: a target seen
        again and lost again emits again). Left out: nothing is emitted.
    ``exclusive`` (bool, default true)
        Claim the role ``track:<name>`` (quota 1) once the name is known (the claim keeps
        other platforms' detectors quiet), bidding the horizontal distance to where the
        target is known to be (:data:`UNSEEN_BID` when nowhere yet: of two holders after a
        partition heals, the nearer keeps the role), and release it on stop; without a swarm behind
        ``ctx.collective`` this is skipped silently. Started by an ``X_lost`` whose data
        lists a ``track:<name>`` role of the lost platform, the name is that target's.
    ``yield_event`` (optional)
        Emitted, scope local, once per start, when the swarm gives the role to another
        platform: the claim was denied (another platform tracks the target) or the grant
        revoked (two held it, after a partition healed). A transition on it back to
        searching leaves one tracker per target. Left out: the answer is ignored and the
        tracker keeps tracking.

    ``area`` (optional)
        Where to look when the target is nowhere known or is lost: an area name of
        ``ctx.areas`` or ``"x_min y_min x_max y_max"``, as for ``search.area``. The tracker
        then sweeps the whole area in lanes (``1.6 · search_altitude`` apart) at
        ``search_altitude``, from the lane end nearest to it, until its camera sees the
        target. This is what a platform
        promoted by ``Track_lost`` needs: it was told to track but not where the target
        is. Left out: the tracker hovers where it is (or over the last known position).
    ``search_altitude`` (float > 0, default 35)
        The altitude of that sweep (higher: a wider footprint).

    A promoted tracker (no position given) that knows the target's name from the lost
    tracker's role claims the role at start and, with ``area``, flies first to where the
    lost tracker last was (at ``search_altitude``), then sweeps the area from there.

    Where the target is and how it is followed: see the module docstring. A camera is used
    when the platform has one; without one the tracker flies to the last position it was
    given and hovers there. The lost countdown runs from the last sighting, or from the
    start (activation, for a restored instance) when there was none; a lost tracker keeps
    hovering over the last known position and picks the target up again if it comes into
    view. The snapshot is ``{"last": [x, y, z] or None, "seen_at": t or None, "lost":
    bool}``, plus ``"seen_after_task": s`` (``seen_at`` counted from the task's start) where
    the task's clock is known: restored after a reboot (a new clock), the countdown goes
    on from ``s`` seconds after the task's start.
    """

    bus = "act_bus"
    resources = frozenset({"autopilot"})
    needs_vehicle = True
    params: ClassVar[Mapping[str, Param]] = {
        "altitude": Param(
            kind="float",
            default=20.0,
            minimum=0.0,
            doc="metres above the ground to follow the target at (> 0)",
        ),
        **_filter_params(),
        "lost_after": Param(
            kind="float",
            default=10.0,
            minimum=0.0,
            doc="seconds without a sighting after which the target is lost (> 0)",
        ),
        "lost_event": Param(
            kind="str",
            pattern=EVENT_NAME_PATTERN,
            form=EVENT_NAME_FORM,
            doc="the event to emit when the target becomes lost; left out: none",
        ),
        "exclusive": Param(
            kind="bool",
            default=True,
            doc="claim the target's tracker role (quota 1) once its name is known, so other "
            "platforms' detectors stay quiet",
        ),
        "yield_event": Param(
            kind="str",
            pattern=EVENT_NAME_PATTERN,
            form=EVENT_NAME_FORM,
            doc="the event to emit when the swarm gives the target's tracker role to "
            "another platform; left out: none (keep tracking)",
        ),
        "area": Param(
            kind="area",
            doc="an area name or 'x_min y_min x_max y_max' to sweep while the target is "
            "unknown or lost; left out: hover",
        ),
        "search_altitude": Param(
            kind="float",
            default=35.0,
            minimum=0.0,
            doc="metres above the ground of that sweep (> 0)",
        ),
    }

    def __init__(self) -> None:
        self._last: Point | None = None  # where the target was last known to be
        self._seen_at: float | None = None  # when it was last seen (None: never)
        self._lost = False
        self._since = 0.0  # the lost countdown's origin when nothing was seen
        self._name: str | None = None  # the target locked on
        self._velocity: tuple[float, float] = (0.0, 0.0)
        self._sent: Point | None = None
        self._holding = False
        self._claimed: str | None = None
        self._cursor = 0  # role answers on the blackboard before this index are not ours
        self._yielded = False
        self._sweep: list[Point] = []  # the area's lanes, while looking for the target
        self._leg = 0
        self._hint: Point | None = None  # where a lost tracker last was: looked at first
        # seen_at as the snapshot also keeps it: counted from the task's start.
        self._seen_clock = TaskTime()

    @property
    def last(self) -> Point | None:
        """Where the target was last known to be (None: nowhere yet)."""
        return self._last

    @property
    def lost(self) -> bool:
        """Whether the target counts as lost now."""
        return self._lost

    def on_start(self, ctx: PluginContext) -> None:
        altitude = float(ctx.params["altitude"])
        lost_after = float(ctx.params["lost_after"])
        if altitude <= 0:
            raise ValueError(f"track.target: altitude must be > 0 metres, not {altitude:g}")
        if lost_after <= 0:
            raise ValueError(f"track.target: lost_after must be > 0 seconds, not {lost_after:g}")
        ctx.require_vehicle()
        self._plan_sweep(ctx)
        self._last, self._seen_at, self._lost = None, None, False
        self._seen_clock.start(ctx.task_start)
        self._since = ctx.now
        self._yielded = False
        event = ctx.data.get("event") if isinstance(ctx.data, Mapping) else None
        for source in (ctx.data, event):
            given = _xyz(source)
            if given is not None and isinstance(source, Mapping):
                self._last = given
                self._lock(source.get("target"))
                break
        self._lock(ctx.params["target"])
        self._hint = None
        taken_over = _lost_tracker(ctx)
        if taken_over is not None and self._name in (None, taken_over[0]):
            self._lock(taken_over[0])
            # The lost tracker flew over the target: look there first (unless the
            # transition brought where the target itself is).
            self._hint = taken_over[1] if self._last is None else None
        self._observe(ctx)
        self._command(ctx, force=True)

    def step(self, ctx: PluginContext) -> None:
        self._observe(ctx)
        self._check_role(ctx)
        reference = self._seen_at if self._seen_at is not None else self._since
        if not self._lost and ctx.now - reference >= float(ctx.params["lost_after"]):
            self._lost = True
            if ctx.params["lost_event"] is not None:
                ctx.emit(ctx.params["lost_event"], scope="local")
        self._command(ctx, force=False)

    def on_activate(self, ctx: PluginContext) -> None:
        if not self._sweep:  # restored from a snapshot: the sweep is not part of it
            self._plan_sweep(ctx)
        # Restored: the last sighting, counted from the task's start, on this clock.
        self._seen_at = self._seen_clock.activate(self._seen_at, ctx.task_start)
        self._since = ctx.now
        self._sent, self._holding = None, False
        self._observe(ctx)
        self._command(ctx, force=True)

    def on_stop(self, ctx: PluginContext) -> None:
        if self._claimed is not None:
            with contextlib.suppress(CollectiveUnavailable):
                ctx.collective.release_role(self._claimed)
            self._claimed = None

    def snapshot(self) -> dict[str, Any]:
        state: dict[str, Any] = {
            "last": None if self._last is None else list(self._last),
            "seen_at": self._seen_at,
            "lost": self._lost,
        }
        after = self._seen_clock.after(self._seen_at)
        if after is not None:
            state["seen_after_task"] = after
        return state

    def restore(self, state: Mapping[str, Any]) -> None:
        last, seen_at = state.get("last"), state.get("seen_at")
        point = None if last is None else read_point("track.target", "last", last)
        if seen_at is not None and not finite(seen_at):
            raise ValueError(
                f"track.target: a snapshot's 'seen_at' must be a time or null, not {seen_at!r}"
            )
        self._lost = read_flag("track.target", state, "lost")
        after = read_time("track.target", state, "seen_after_task")
        self._last = point
        self._seen_at = None if seen_at is None else float(seen_at)
        self._seen_clock.restored(None if seen_at is None else after)

    # --- where the target is ------------------------------------------------------------------

    def _lock(self, name: object) -> None:
        if self._name is None and isinstance(name, str) and name:
            self._name = name

    def _observe(self, ctx: PluginContext) -> None:
        """Update the target's position from the camera, else from a newer blackboard
        sighting; claim the role once the name is known."""
        self._lock(ctx.params["target"])
        seen = _matching(ctx, self._name)
        if seen:
            d = seen[0]
            self._lock(d.name)
            self._sighting(d.position, ctx.now)
        else:
            self._from_blackboard(ctx)
        self._claim(ctx)

    def _from_blackboard(self, ctx: PluginContext) -> None:
        entry = ctx.blackboard.get("target")
        where = _xyz(entry)
        if where is None or not isinstance(entry, Mapping):
            return
        name, kind, t = entry.get("name"), entry.get("kind"), entry.get("t")
        want = self._name if self._name is not None else ctx.params["target"]
        if (want is not None and name != want) or (
            ctx.params["kind"] is not None and kind != ctx.params["kind"]
        ):
            return
        if finite(t):
            assert isinstance(t, int | float)
            if self._seen_at is not None and t <= self._seen_at:
                return
            self._lock(name)
            self._sighting(where, float(t))
        elif self._last is None:
            self._lock(name)
            self._last = where

    def _sighting(self, where: Point, t: float) -> None:
        if self._last is not None and self._seen_at is not None and t > self._seen_at:
            dt = t - self._seen_at
            self._velocity = ((where[0] - self._last[0]) / dt, (where[1] - self._last[1]) / dt)
        self._last, self._seen_at, self._lost = where, t, False

    def _claim(self, ctx: PluginContext) -> None:
        if self._claimed is not None or self._name is None or not ctx.params["exclusive"]:
            return
        role = track_role(self._name)
        before = _answers_so_far(ctx)
        # The bid ranks the holders when two hold the role (a healed partition): the one
        # nearer to the target keeps it, and one that has not seen it yet goes last.
        if self._last is None:
            bid = UNSEEN_BID
        else:
            here = ctx.require_vehicle().position()
            bid = math.hypot(here[0] - self._last[0], here[1] - self._last[1])
        try:
            ctx.collective.claim_role(role, 1, bid=bid)
        except CollectiveUnavailable:
            return
        self._claimed, self._cursor = role, before

    def _check_role(self, ctx: PluginContext) -> None:
        """Emit ``yield_event`` once if the swarm gave the claimed role to another."""
        event = ctx.params["yield_event"]
        if self._claimed is None or event is None or self._yielded:
            return
        state, self._cursor = _role_state(ctx, self._claimed, self._cursor)
        if state in ("denied", "revoked"):
            self._yielded = True
            ctx.emit(event, scope="local")

    # --- following it -------------------------------------------------------------------------

    def _command(self, ctx: PluginContext, *, force: bool) -> None:
        vehicle = ctx.require_vehicle()
        if self._sweep and (self._last is None or self._lost):
            self._look(ctx, force=force)
            return
        if self._last is None:
            if force or not self._holding:
                vehicle.hold()
                self._holding = True
            return
        point = (self._last[0], self._last[1], float(ctx.params["altitude"]))
        unchanged = self._sent is not None and math.dist(point, self._sent) < RECOMMAND_DISTANCE
        if unchanged and not force:
            return
        gap = math.dist(vehicle.position(), point)
        speed = max(_MIN_SPEED, math.hypot(*self._velocity) + gap / CATCH_UP_TIME)
        vehicle.goto(*point, speed=speed)
        self._sent, self._holding = point, False

    def _plan_sweep(self, ctx: PluginContext) -> None:
        """The lanes over ``area`` (none without one); ValueError for a bad area."""
        self._sweep, self._leg = [], 0
        area = ctx.params["area"]
        if area is None:
            return
        search_altitude = float(ctx.params["search_altitude"])
        if search_altitude <= 0:
            raise ValueError(
                f"track.target: search_altitude must be > 0 metres, not {search_altitude:g}"
            )
        polygon = parse_area(str(area), ctx.areas)
        self._sweep = lanes(polygon, 1, 1, LANE_PER_ALTITUDE * search_altitude, search_altitude)

    def _look(self, ctx: PluginContext, *, force: bool) -> None:
        """Fly the sweep of ``area``, lane after lane and round again, until a sighting;
        it begins at the waypoint nearest the vehicle, not across the area."""
        vehicle = ctx.require_vehicle()
        if self._hint is not None:
            point = (self._hint[0], self._hint[1], float(ctx.params["search_altitude"]))
            if math.dist(vehicle.position(), point) > _SWEEP_TOLERANCE:
                if force or self._sent != point:
                    vehicle.goto(*point)
                    self._sent, self._holding = point, False
                return
            # Not there (any more): sweep on from the lane end nearest to here.
            self._hint, self._sent, self._leg = None, None, 0
        if self._leg == 0 and self._sent is None:
            here = vehicle.position()
            self._leg = min(range(len(self._sweep)), key=lambda i: math.dist(here, self._sweep[i]))
        point = self._sweep[self._leg % len(self._sweep)]
        if math.dist(vehicle.position(), point) <= _SWEEP_TOLERANCE:
            self._leg += 1
            point = self._sweep[self._leg % len(self._sweep)]
            force = True
        if force or self._sent != point:
            vehicle.goto(*point)
            self._sent, self._holding = point, False
