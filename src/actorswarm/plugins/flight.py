"""The flight plugins (docs/design.md §6): take off, go to a point, return home.

``flight.takeoff`` (:class:`TakeOff`)
    The paper's *Standby* actor: take off to ``altitude`` and hover; emit ``event``
    (``ready_event``) once there.
``flight.goto`` (:class:`GoTo`)
    The paper's *Ingress* actor: fly to ``target`` — or to the ``TargetPoint`` the switching
    transition gives — and hover; emit ``event`` (``arriving_event``) once within
    ``tolerance`` of it.
``flight.return_home`` (:class:`ReturnHome`)
    The paper's *Return* actor (switched in by ``go_home_event``): fly to ``home`` at
    ``altitude``, land there, and emit ``event`` (``landed_event``) once on the ground; a
    group given a ``rally`` point first flies there together, keeping its shape.

Theory of operation
-------------------
Each plugin sits on ``act_bus``, holds the ``autopilot`` resource and needs a vehicle. It
works the way an autopilot is meant to be used: it sets a goal once and then *watches*.

* ``on_start`` sends the one command that starts the manoeuvre (``takeoff``, ``goto``).
  Commands return at once (:class:`~actorswarm.runtime.context.Vehicle`); the vehicle's own
  controller flies the path.
* ``step`` reads :meth:`~actorswarm.runtime.context.Vehicle.position` and compares it with
  the goal. When the goal is reached it emits the plugin's *arrival event* — exactly once
  per start — and tells the vehicle to hold (or, for :class:`ReturnHome`, to land, and
  emits once it is down). A step never blocks and never sends a command while nothing
  changed, so a plugin stepped at any rate costs a comparison per step.
* ``on_pause`` sends nothing: the actor that preempted this one owns the autopilot now.
  ``on_activate`` re-sends the command of the current phase, since that actor may have
  moved the vehicle; once the event has gone out it only holds (lands, for
  :class:`ReturnHome`) where the vehicle is.
* ``snapshot`` is the phase and what the plugin resolved at start (the target point, the
  home it remembered), so a restored instance resumes the same manoeuvre from
  ``on_activate``, on whatever host restores it, and never emits its event a second time.

None of them has a timer of its own (``next_deadline`` is None): they are stepped at the
actor's rate, which is what watching a moving vehicle needs. Positions are metres in the
mission's local frame (x east, y north, z up); the ground is at z = 0.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, ClassVar, Final

from actorswarm.plugins.snapshot import TaskTime, finite, read_flag, read_point, read_time
from actorswarm.runtime.builtin import EVENT_NAME_FORM, EVENT_NAME_PATTERN
from actorswarm.runtime.plugin import Param, Plugin, Point

if TYPE_CHECKING:
    from actorswarm.runtime.context import PluginContext, Vehicle

__all__ = ["GoTo", "ReturnHome", "TakeOff"]

#: A vehicle this low (metres) and this slow (m/s) is on the ground.
LANDED_ALTITUDE: Final = 0.2
LANDED_SPEED: Final = 0.1
#: A vehicle above this (metres) has left the ground. Not LANDED_ALTITUDE: a real
#: autopilot's height on the ground wanders before arming (ArduPlane SITL 4.5.7 between
#: -0.22 and +0.40 m in 73 take-offs), so "above 0.2 m" would call an aircraft still
#: standing on its runway airborne.
OFF_GROUND_ALTITUDE: Final = 1.0


#: How many transit layers a formation changing shape is spread over (the formations'
#: ``transit_step``), half below its altitude and half above.
TRANSIT_LAYERS: Final = 4
#: How many layers a group flying home is spread over (``flight.return_home``'s
#: ``layer_step``), from its altitude up, unless its ``layers`` says otherwise.
HOME_LAYERS: Final = 6


def _scope_param() -> Param:
    return Param(
        kind="str",
        default="local",
        choices=("local", "swarm"),
        doc="local: only this platform becomes a candidate for the event's transition; "
        "swarm: every platform whose actor has one",
    )


def _event_param(default: str, when: str) -> Param:
    return Param(
        kind="str",
        default=default,
        pattern=EVENT_NAME_PATTERN,
        form=EVENT_NAME_FORM,
        doc=f"the event to emit, once, {when}",
    )


def _distance(a: Sequence[float], b: Sequence[float]) -> float:
    return math.dist(tuple(a), tuple(b))


def _speed(vehicle: Vehicle) -> float:
    vx, vy, vz = vehicle.velocity()
    return math.sqrt(vx * vx + vy * vy + vz * vz)


class TakeOff(Plugin):
    """``flight.takeoff``: take off, climb to ``altitude``, emit ``event`` there, hover.

    Params:

    ``altitude`` (float > 0, default 20)
        Metres above the ground to climb to.
    ``tolerance`` (float ≥ 0, default 1)
        How close to ``altitude`` (metres, vertically) counts as arrived.
    ``event`` (default ``ready_event``)
        The arrival event, emitted once per start on the first step at which the vehicle
        is within ``tolerance`` of ``altitude``; the plugin then tells the vehicle to hold.
    ``scope`` (``local``, the default, or ``swarm``)
        The event's scope (:meth:`~actorswarm.runtime.context.PluginContext.emit`).
    ``layers`` (int ≥ 1, default 1), ``layer_step`` (float ≥ 0, default 0), ``stagger``
        (float ≥ 0, default 0)
        Take-offs deconflicted for aircraft that cannot hover: platform ``p`` is on layer
        ``k = (p - 1) mod layers``, climbs to ``altitude + k · layer_step`` (and its event
        fires there) and takes off ``k · stagger`` seconds after the actor started — so
        neighbours on a field neither roll at once nor circle at one altitude. The defaults
        take everyone off at once to ``altitude``.
    ``late_after`` (float ≥ 0, default 0: off), ``late_below`` (float ≥ 0, default 15)
        A late take-off kept clear of the others' holding circles. An aircraft that cannot
        hover circles where it reached its altitude, on its own row's climb-out line; one
        whose autopilot is late (still on the ground, under 1 m, ``late_after`` seconds
        after its turn) would climb through the circles of the aircraft ahead of it at
        their altitude. Such an aircraft is sent up to ``altitude − late_below`` instead
        (a second ``takeoff``, which replaces the one still waiting) and its event fires
        there: it holds under the lowest layer, ``late_below`` (more than the separation)
        below it, and joins from there when the actor hands over.

    A vehicle already in the air within ``tolerance`` of ``altitude`` when the actor starts
    gets no take-off command: the event goes out on the first step. (One in the air at
    another altitude is sent ``takeoff``, which moves it to ``altitude`` where it is.)

    The snapshot is ``{"fired": bool, "low": bool}`` (``low``: a late take-off, holding
    under the others; a snapshot without it is not late). A restored or re-activated
    instance that has not fired yet sends ``takeoff`` again (to the lower altitude when
    late); one that has fired holds.
    """

    bus = "act_bus"
    resources = frozenset({"autopilot"})
    needs_vehicle = True
    params: ClassVar[Mapping[str, Param]] = {
        "altitude": Param(
            kind="float",
            default=20.0,
            minimum=0.0,
            doc="metres above the ground to climb to (> 0)",
        ),
        "tolerance": Param(
            kind="float",
            default=1.0,
            minimum=0.0,
            doc="metres from altitude (vertically) that count as arrived",
        ),
        "event": _event_param("ready_event", "when the vehicle reaches the altitude"),
        "scope": _scope_param(),
        "layers": Param(
            kind="int",
            default=1,
            minimum=1,
            doc="platform p takes off on layer (p - 1) mod layers",
        ),
        "layer_step": Param(
            kind="float",
            default=0.0,
            minimum=0.0,
            doc="metres between two take-off layers (layer k climbs to altitude + k · step)",
        ),
        "stagger": Param(
            kind="float",
            default=0.0,
            minimum=0.0,
            doc="seconds between two layers' take-offs (layer k waits k · stagger)",
        ),
        "late_after": Param(
            kind="float",
            default=0.0,
            minimum=0.0,
            doc="an aircraft still on the ground this many seconds after its turn holds "
            "below the others (0: never)",
        ),
        "late_below": Param(
            kind="float",
            default=15.0,
            minimum=0.0,
            doc="metres under altitude a late aircraft holds at",
        ),
    }

    def __init__(self) -> None:
        self._fired = False
        # When this platform's take-off goes out (its layer's turn), None once sent.
        self._due: float | None = None
        # When its turn came (the take-off asked), until it leaves the ground; then None.
        self._asked: float | None = None
        # Off the ground late: it holds under the others (late_after).
        self._low = False

    def _altitude(self, ctx: PluginContext) -> float:
        if self._low:
            return float(ctx.params["altitude"]) - float(ctx.params["late_below"])
        return float(ctx.params["altitude"]) + self._layer(ctx) * float(ctx.params["layer_step"])

    @staticmethod
    def _layer(ctx: PluginContext) -> int:
        return (ctx.platform - 1) % int(ctx.params["layers"])

    def on_start(self, ctx: PluginContext) -> None:
        altitude = float(ctx.params["altitude"])
        if altitude <= 0:
            raise ValueError(f"flight.takeoff: altitude must be > 0 metres, not {altitude:g}")
        below = float(ctx.params["late_below"])
        if ctx.params["late_after"] > 0 and below >= altitude:
            raise ValueError(
                f"flight.takeoff: late_below ({below:g} m) must be under altitude "
                f"({altitude:g} m): a late aircraft holds that far below it"
            )
        vehicle = ctx.require_vehicle()
        self._fired = False
        self._due = None
        self._low = False
        z = vehicle.position()[2]
        self._asked = None
        if not (
            z > OFF_GROUND_ALTITUDE and abs(z - self._altitude(ctx)) <= ctx.params["tolerance"]
        ):
            wait = self._layer(ctx) * float(ctx.params["stagger"])
            if z <= OFF_GROUND_ALTITUDE:
                self._asked = ctx.now + wait
            if wait > 0:
                self._due = ctx.now + wait
            else:
                vehicle.takeoff(self._altitude(ctx))

    def step(self, ctx: PluginContext) -> None:
        if self._fired:
            return
        vehicle = ctx.require_vehicle()
        if self._due is not None:
            if ctx.now < self._due:
                return
            self._due = None
            vehicle.takeoff(self._altitude(ctx))
        z = vehicle.position()[2]
        if self._asked is not None:
            late_after = float(ctx.params["late_after"])
            if z > OFF_GROUND_ALTITUDE:
                self._asked = None  # off the ground in time
            elif late_after > 0 and ctx.now - self._asked > late_after:
                # Its autopilot is late: the others hold on their circles above the field,
                # and its climb-out would cross them. It is sent under them instead, while
                # still on the ground (a real autopilot then takes off straight to the
                # lower altitude, rather than being turned back in its climb).
                self._low = True
                self._asked = None
                vehicle.takeoff(self._altitude(ctx))
        if abs(z - self._altitude(ctx)) <= ctx.params["tolerance"]:
            self._fired = True
            ctx.emit(ctx.params["event"], scope=ctx.params["scope"])
            vehicle.hold()

    def on_activate(self, ctx: PluginContext) -> None:
        vehicle = ctx.require_vehicle()
        if self._fired:
            vehicle.hold()
        elif self._due is None:
            vehicle.takeoff(self._altitude(ctx))

    def snapshot(self) -> dict[str, Any]:
        return {"fired": self._fired, "low": self._low}

    def restore(self, state: Mapping[str, Any]) -> None:
        self._fired = read_flag("flight.takeoff", state, "fired")
        self._low = "low" in state and read_flag("flight.takeoff", state, "low")


class GoTo(Plugin):
    """``flight.goto``: fly to a point, emit ``event`` once within ``tolerance``, hover.

    Params:

    ``target`` (point ``"x y z"``)
        Where to fly, metres. Required unless ``TargetPoint`` is given.
    ``TargetPoint`` (point ``"x y z"``)
        The same, under the name the paper's transitions use
        (``<param TargetPoint "200 200 20">`` on the transition that switches the actor
        in). **When both are given, TargetPoint wins**: a transition's params are laid over
        the script's, so the transition names the point and ``target`` in the script is
        the fallback. Starting with neither raises ValueError.
    ``speed`` (float > 0, optional)
        Ground speed in m/s; left out: the vehicle's cruise speed.
    ``tolerance`` (float ≥ 0, default 5)
        How close to the point (metres, straight-line) counts as arrived.
    ``event`` (default ``arriving_event``)
        The arrival event, emitted once per start on the first step within ``tolerance``;
        the plugin then tells the vehicle to hold.
    ``scope`` (``local``, the default, or ``swarm``)
        The event's scope.
    ``spacing`` (float ≥ 0, default 0)
        When a group is sent (``ctx.slots`` > 1), each member flies to its own place on a
        grid around the point, ``spacing`` metres apart (slot ``k``: the ``k``-th place of
        :func:`~actorswarm.plugins.formation.slots` ``("grid", slots, spacing)``, the grid
        centred on the point), which the master hands out by
        :mod:`actorswarm.engine.assign`. 0: every member flies to the point itself — they
        meet there, which ``actorswarm task check --world`` warns about.

    A vehicle on the ground takes off on its way (what the vehicle does with a ``goto``).
    The snapshot is ``{"target": [x, y, z], "fired": bool}``: the point resolved at start,
    so a restored instance flies to the same point whatever params it is given.
    """

    bus = "act_bus"
    resources = frozenset({"autopilot"})
    needs_vehicle = True
    # A group sent to a grid around one point flies there at one speed from about as far
    # away (a translated grid): about in step, so the places go by least squared distance.
    group_in_step = True
    params: ClassVar[Mapping[str, Param]] = {
        "target": Param(
            kind="point",
            doc='where to fly, "x y z" metres (required unless TargetPoint is given)',
        ),
        "TargetPoint": Param(
            kind="point",
            doc='where to fly, "x y z" metres, usually from the switching transition; '
            "wins over target",
        ),
        "speed": Param(
            kind="float",
            minimum=0.0,
            doc="ground speed in m/s (> 0); left out: the vehicle's cruise speed",
        ),
        "tolerance": Param(
            kind="float",
            default=5.0,
            minimum=0.0,
            doc="metres from the point that count as arrived",
        ),
        "event": _event_param("arriving_event", "when the vehicle is within tolerance"),
        "scope": _scope_param(),
        "spacing": Param(
            kind="float",
            default=0.0,
            minimum=0.0,
            doc="metres between the places of a group's members on a grid around the "
            "point; 0: every member to the point itself",
        ),
    }

    def __init__(self) -> None:
        self._target: Point | None = None
        self._fired = False

    @staticmethod
    def places(count: int, spacing: float) -> list[tuple[float, float]]:
        """The offsets of ``count`` members' places from the point: a grid ``spacing``
        apart, centred on it (all ``(0, 0)`` when ``spacing`` is 0)."""
        if count < 1:
            return []
        if spacing <= 0:
            return [(0.0, 0.0)] * count
        from actorswarm.plugins.formation import slots

        grid = slots("grid", count, spacing)
        centre = (grid.max(axis=0) + grid.min(axis=0)) / 2.0
        return [(float(x), float(y)) for x, y in (grid - centre).tolist()]

    @classmethod
    def group_points(
        cls,
        params: Mapping[str, Any],
        count: int,
        now: float,
        areas: Mapping[str, Sequence[tuple[float, float]]],
        *,
        task_start: float | None = None,
    ) -> list[tuple[float, float]] | None:
        """The members' places around the point (``spacing``), or None without spacing
        (every member goes to the same point, so there is nothing to hand out)."""
        spacing = float(params.get("spacing") or 0.0)
        if spacing <= 0:
            return None
        x, y, _ = cls.resolve_target(params)
        return [(x + dx, y + dy) for dx, dy in cls.places(count, spacing)]

    @staticmethod
    def resolve_target(params: Mapping[str, Any]) -> Point:
        """The point to fly to: ``TargetPoint`` when given, else ``target``; ValueError
        when neither is."""
        point = params.get("TargetPoint")
        if point is None:
            point = params.get("target")
        if point is None:
            raise ValueError(
                'flight.goto: no point to fly to; give <param target "x y z"> in the script '
                "or TargetPoint on the transition that switches the actor in"
            )
        return read_point("flight.goto", "target", point)

    def on_start(self, ctx: PluginContext) -> None:
        x, y, z = self.resolve_target(ctx.params)
        spacing = float(ctx.params.get("spacing") or 0.0)
        if spacing > 0 and ctx.slots > 1 and 1 <= ctx.slot <= ctx.slots:
            dx, dy = self.places(ctx.slots, spacing)[ctx.slot - 1]
            x, y = x + dx, y + dy
        self._target = (x, y, z)
        self._fired = False
        self._command(ctx)

    def step(self, ctx: PluginContext) -> None:
        if self._fired or self._target is None:
            return
        vehicle = ctx.require_vehicle()
        if _distance(vehicle.position(), self._target) <= ctx.params["tolerance"]:
            self._fired = True
            ctx.emit(ctx.params["event"], scope=ctx.params["scope"])
            vehicle.hold()

    def on_activate(self, ctx: PluginContext) -> None:
        if self._fired:
            ctx.require_vehicle().hold()
        else:
            self._command(ctx)

    def snapshot(self) -> dict[str, Any]:
        return {
            "target": None if self._target is None else list(self._target),
            "fired": self._fired,
        }

    def restore(self, state: Mapping[str, Any]) -> None:
        self._target = read_point("flight.goto", "target", state.get("target"))
        self._fired = read_flag("flight.goto", state, "fired")

    def _command(self, ctx: PluginContext) -> None:
        if self._target is None:
            return
        speed = ctx.params["speed"]
        if speed is not None and speed <= 0:
            raise ValueError(f"flight.goto: speed must be > 0 m/s, not {speed:g}")
        x, y, z = self._target
        ctx.require_vehicle().goto(x, y, z, speed=None if speed is None else float(speed))


class ReturnHome(Plugin):
    """``flight.return_home``: fly home at ``altitude``, land, emit ``event`` once down.

    Params:

    ``home`` (point ``"x y z"``, optional)
        Where home is. Left out: the vehicle's home point when it has one (``home()``, as
        the simulated world's vehicles do), else where the vehicle was when this plugin
        first started (kept in the snapshot, so a restored instance goes to the same place).
        Only x and y are used: the vehicle travels at ``altitude`` and lands on the ground
        below.
    ``altitude`` (float > 0, default 20)
        Metres above the ground to travel home at.
    ``land`` (bool, default true)
        Land at home. With false the vehicle hovers over home at ``altitude`` instead.
    ``tolerance`` (float ≥ 0, default 1)
        How close to the point over home (metres, straight-line) counts as there.
    ``event`` (default ``landed_event``)
        Emitted once per start: when the vehicle is down at home (below 0.2 m and slower
        than 0.1 m/s), or, with ``land`` false, when it is over home.
    ``scope`` (``local``, the default, or ``swarm``)
        The event's scope.
    ``layer_step`` (float ≥ 0, default 0)
        Members of a group sent home together travel on ``layers`` layers, slot ``k`` at
        ``altitude + ((k - 1) mod layers) · layer_step``, so that the paths of neighbours
        that cross on the way home pass above each other; 0: all at ``altitude``.
    ``layers`` (int ≥ 0, default :data:`HOME_LAYERS`)
        How many layers; 0: one per member (``ctx.slots``), so that no two members of the
        group share an altitude and, with ``layer_step`` above the separation, two members
        level on their layers cannot meet however their paths cross. (A landing still
        descends through the layers below it.)
    ``land_stagger`` (float ≥ 0, default 0)
        Landings in turn: the member on layer ``k`` lands ``k · land_stagger`` seconds
        after it is first over home, waiting there (a fixed-wing circling it, on its layer)
        until then — so aircraft that come home together (a group sent home with a
        ``rally``) do not share the approach at once. Counted from its own arrival, not from
        the start: the way home takes longer than one stagger, and the member on layer 1
        would otherwise land with the one on layer 0. Members that come home far apart in
        time are not sequenced by it. 0: each lands as soon as it is over home.
    ``rally`` (point ``"x y z"``, optional; z unused)
        Where a group sent home together (``ctx.slots`` > 1) flies first, *keeping its
        shape*: each member flies to ``rally + (its position − the group's centre)``, the
        centre being the one point the master scattered to all of them (``ctx.data
        ["centre"]``, the mean of the members' positions at the release), at its layer's
        altitude. Every member thus flies the same horizontal vector, the same way, at its
        cruise speed: the group moves as a rigid body, its members as far apart as they
        were when it left (a formation's spacing), however their homes lie, while each
        climbs or descends to its layer. Only from there does each fly to its own home.
        Left out, or without a centre (a single vehicle, a release from an older master):
        straight home.

    The phases are ``rally`` (with a rally point: a ``goto`` to the member's place around
    it, until the member is within ``tolerance`` of it *along the group's way*: every
    member turns for home at the same instant, an aircraft circling its place included),
    ``transit`` (a ``goto`` to the point ``altitude`` metres over home, plus the layer),
    ``landing`` (a ``land`` once within ``tolerance`` of it) and ``done``. A vehicle
    already on the ground at home when the plugin starts skips straight to ``landing``.
    The snapshot is ``{"home": [x, y, z], "phase": str}``, plus ``"layer": k`` above the
    first layer, and ``"rally": [x, y, z]`` (the member's own place) and ``"rally_way":
    [ux, uy, 0]`` (the direction of the group's flight there) in the ``rally`` phase.
    A member waiting over home for its turn adds ``"land_at": t`` (the time on its clock
    it may land) and ``"land_after_task": s`` (the same, counted from the task's start):
    restored after a reboot (a new clock), it lands ``s`` seconds after the task's start.
    """

    bus = "act_bus"
    resources = frozenset({"autopilot"})
    needs_vehicle = True
    params: ClassVar[Mapping[str, Param]] = {
        "home": Param(
            kind="point",
            doc='home, "x y z" metres (z unused); left out: the vehicle\'s home point',
        ),
        "altitude": Param(
            kind="float",
            default=20.0,
            minimum=0.0,
            doc="metres above the ground to travel home at (> 0)",
        ),
        "land": Param(
            kind="bool",
            default=True,
            doc="land at home (false: hover over home at altitude)",
        ),
        "tolerance": Param(
            kind="float",
            default=1.0,
            minimum=0.0,
            doc="metres from the point over home that count as there",
        ),
        "event": _event_param("landed_event", "when the vehicle is down at home"),
        "scope": _scope_param(),
        "layer_step": Param(
            kind="float",
            default=0.0,
            minimum=0.0,
            doc="metres between the layers a group travels home on (slot k on layer "
            "(k - 1) mod layers); 0: one layer",
        ),
        "layers": Param(
            kind="int",
            default=HOME_LAYERS,
            minimum=0,
            doc="how many layers a group travels home on; 0: one per member",
        ),
        "land_stagger": Param(
            kind="float",
            default=0.0,
            minimum=0.0,
            doc="seconds between the landings of two layers (layer k lands k · this after it "
            "is first over home); 0: each as soon as it is over home",
        ),
        "rally": Param(
            kind="point",
            doc='where a group sent home first flies together, keeping its shape, "x y z" '
            "metres (z unused); left out: straight home",
        ),
    }

    _PHASES: ClassVar[tuple[str, ...]] = ("rally", "transit", "landing", "done")

    def __init__(self) -> None:
        self._home: Point | None = None
        self._phase = "transit"
        self._layer = 0
        # The earliest this member may land (its layer's turn; -inf: at once; None: its
        # turn is _land_wait seconds after it is first over home).
        self._land_at: float | None = -math.inf
        self._land_wait = 0.0
        # The member's place around the rally point, and the unit vector (x, y, 0) of the
        # group's flight there: the rally phase ends once that far along it.
        self._rally: Point | None = None
        self._rally_way: Point = (0.0, 0.0, 0.0)
        # land_at as the snapshot also keeps it: counted from the task's start.
        self._land_clock = TaskTime()

    @property
    def home(self) -> Point | None:
        """Where this start flies to (None before the start)."""
        return self._home

    @property
    def phase(self) -> str:
        """``transit``, ``landing`` or ``done``."""
        return self._phase

    def on_start(self, ctx: PluginContext) -> None:
        altitude = float(ctx.params["altitude"])
        if altitude <= 0:
            raise ValueError(f"flight.return_home: altitude must be > 0 metres, not {altitude:g}")
        vehicle = ctx.require_vehicle()
        self._land_clock.start(ctx.task_start)
        layers = int(ctx.params["layers"]) or max(ctx.slots, 1)
        self._layer = (ctx.slot - 1) % layers if ctx.slot > 0 else 0
        self._land_wait = self._layer * float(ctx.params["land_stagger"])
        self._land_at = None if self._land_wait > 0 else -math.inf
        given = ctx.params["home"]
        if given is not None:
            self._home = read_point("flight.return_home", "home", given)
        else:
            # The vehicle's own home when it knows it (the simulated world's vehicles and
            # autopilots with a home point do), else where it was when this plugin started.
            home = getattr(vehicle, "home", None)
            self._home = home() if callable(home) else vehicle.position()
        x, y, z = vehicle.position()
        at_home = math.hypot(x - self._home[0], y - self._home[1]) <= ctx.params["tolerance"]
        on_ground = z <= LANDED_ALTITUDE
        self._phase = "landing" if at_home and on_ground and ctx.params["land"] else "transit"
        self._rally = self._rally_place(ctx, (x, y, z)) if self._phase == "transit" else None
        if self._rally is not None:
            dx, dy = self._rally[0] - x, self._rally[1] - y
            length = math.hypot(dx, dy)
            if length > ctx.params["tolerance"]:
                self._phase = "rally"
                self._rally_way = (dx / length, dy / length, 0.0)
            else:
                self._rally = None
        self._command(ctx)

    def _rally_place(self, ctx: PluginContext, here: Point) -> Point | None:
        """This member's place around the rally point, at its layer's altitude (the class
        docstring), or None when it flies straight home."""
        given = ctx.params["rally"]
        centre = ctx.data.get("centre") if isinstance(ctx.data, Mapping) else None
        if given is None or ctx.slots < 2 or here[2] <= LANDED_ALTITUDE:
            return None
        if not (isinstance(centre, list) and len(centre) == 2 and all(map(finite, centre))):
            return None
        rx, ry, _ = read_point("flight.return_home", "rally", given)
        cx, cy = float(centre[0]), float(centre[1])
        return (rx + here[0] - cx, ry + here[1] - cy, self._over_home(ctx)[2])

    def step(self, ctx: PluginContext) -> None:
        if self._home is None or self._phase == "done":
            return
        vehicle = ctx.require_vehicle()
        if self._phase == "rally":
            assert self._rally is not None
            x, y, _ = vehicle.position()
            ux, uy, _ = self._rally_way
            # Along the group's way rather than straight-line: an aircraft circles its goal
            # (at its loiter radius) and may never come within tolerance of the point, and
            # every member covers the same way at the same speed, so all of them turn for
            # home at the same instant, still in shape.
            if (self._rally[0] - x) * ux + (self._rally[1] - y) * uy <= ctx.params["tolerance"]:
                self._phase = "transit"
                self._rally = None
                self._command(ctx)
            return
        if self._phase == "transit":
            if _distance(vehicle.position(), self._over_home(ctx)) > ctx.params["tolerance"]:
                return
            if ctx.params["land"]:
                if self._land_at is None:  # first over home: its turn counts from now
                    self._land_at = ctx.now + self._land_wait
                if ctx.now < self._land_at:
                    return  # not its turn yet: it waits over home
                self._phase = "landing"
                vehicle.land()
                return
            self._finish(ctx)
            vehicle.hold()
        elif vehicle.position()[2] <= LANDED_ALTITUDE and _speed(vehicle) <= LANDED_SPEED:
            self._finish(ctx)

    def on_activate(self, ctx: PluginContext) -> None:
        # Restored: its turn, counted from the task's start, on this (maybe new) clock.
        self._land_at = self._land_clock.activate(self._land_at, ctx.task_start)
        self._command(ctx)

    def snapshot(self) -> dict[str, Any]:
        state: dict[str, Any] = {
            "home": None if self._home is None else list(self._home),
            "phase": self._phase,
        }
        if self._layer:
            state["layer"] = self._layer
        if self._rally is not None:
            state["rally"] = list(self._rally)
            state["rally_way"] = list(self._rally_way)
        if self._land_at is None:
            state["land_wait"] = self._land_wait
        elif math.isfinite(self._land_at):
            state["land_at"] = self._land_at
            after = self._land_clock.after(self._land_at)
            if after is not None:
                state["land_after_task"] = after
        return state

    def restore(self, state: Mapping[str, Any]) -> None:
        phase = state.get("phase")
        if phase not in self._PHASES:
            raise ValueError(
                f"flight.return_home: a snapshot's 'phase' must be one of "
                f"{', '.join(self._PHASES)}, not {phase!r}"
            )
        self._home = read_point("flight.return_home", "home", state.get("home"))
        layer = state.get("layer", 0)
        if not (isinstance(layer, int) and not isinstance(layer, bool) and layer >= 0):
            raise ValueError(
                f"flight.return_home: a snapshot's 'layer' must be a whole number ≥ 0, "
                f"not {layer!r}"
            )
        self._layer = layer
        land_at = state.get("land_at", -math.inf)
        if not (isinstance(land_at, int | float) and not isinstance(land_at, bool)):
            raise ValueError(
                f"flight.return_home: a snapshot's 'land_at' must be a number, not {land_at!r}"
            )
        self._land_at = float(land_at)
        self._land_clock.restored(read_time("flight.return_home", state, "land_after_task"))
        wait = state.get("land_wait", 0.0)
        if not (isinstance(wait, int | float) and not isinstance(wait, bool) and wait >= 0):
            raise ValueError(
                f"flight.return_home: a snapshot's 'land_wait' must be a number of seconds "
                f"≥ 0, not {wait!r}"
            )
        self._land_wait = float(wait)
        if self._land_wait > 0 and "land_at" not in state:
            self._land_at = None  # not over home yet when the snapshot was taken
        self._rally = None
        if phase == "rally":
            self._rally = read_point("flight.return_home", "rally", state.get("rally"))
            self._rally_way = read_point("flight.return_home", "rally_way", state.get("rally_way"))
        self._phase = str(phase)

    def _over_home(self, ctx: PluginContext) -> Point:
        assert self._home is not None
        step = float(ctx.params["layer_step"])
        return (self._home[0], self._home[1], float(ctx.params["altitude"]) + self._layer * step)

    def _finish(self, ctx: PluginContext) -> None:
        self._phase = "done"
        ctx.emit(ctx.params["event"], scope=ctx.params["scope"])

    def _command(self, ctx: PluginContext) -> None:
        """Send the command of the current phase."""
        if self._home is None:
            return
        vehicle = ctx.require_vehicle()
        if self._phase == "rally" and self._rally is not None:
            vehicle.goto(*self._rally)
        elif self._phase == "transit":
            vehicle.goto(*self._over_home(ctx))
        elif self._phase == "landing" or ctx.params["land"]:
            vehicle.land()
        else:
            vehicle.hold()
