"""What a plugin sees of the world: :class:`PluginContext`, and the interfaces behind it.

Theory of operation
-------------------
A plugin never reaches out: everything it may use comes in through the context the runtime
hands to each hook. That is what makes one plugin run unchanged in the deterministic
simulator, on a real platform, and in a unit test:

* **Time** is ``ctx.now``, set by the host before each call — virtual seconds in the
  simulator, wall-clock seconds on a platform. A plugin never reads a clock.
* **Randomness** is ``ctx.rng``, a :class:`random.Random` the host seeds, so a seeded run
  replays exactly.
* **The vehicle** is ``ctx.vehicle``, a :class:`Vehicle`: the simulated world and each real
  autopilot adapter implement the same small interface. It is None on a platform without a
  vehicle (and in the simulator's ``--no-world`` mode).
* **The camera** is ``ctx.camera``, a :class:`Camera` reporting the targets in view as
  :class:`Detection` s (the simulated world's, or a real detector's adapter); None without
  one. **Named areas** of the mission (``ctx.areas``: name → polygon) come from the host
  too — the world file in the simulator, the platform's config on a robot — so a script
  can say ``area="search"`` and stay vehicle- and site-agnostic.
* **Events** go out with :meth:`PluginContext.emit`; the context collects them and the host
  takes them with :meth:`PluginContext.drain` after the call, so nothing is sent from inside
  a plugin.
* **Swarm coordination** (barriers, roles) goes through ``ctx.collective``, a
  :class:`Collective` the runtime wires to the platform's core node.
* **ROS 2**, on a daemon started with ``--ros2``, is ``ctx.ros2``: the platform's one ROS 2
  node (:class:`actorswarm.ros2.platform.PlatformRos`) to subscribe, publish and call
  services through, without making nodes or spinning; None elsewhere.
* **Sharing** between the plugins of one actor goes through ``ctx.blackboard``, one dict per
  actor instance: an observe plugin writes ``blackboard["target"]``, a decide plugin reads it.

One context serves one plugin of one actor start: ``params`` are that plugin's, validated;
``blackboard`` is shared with the actor's other plugins.
"""

from __future__ import annotations

import math
import random
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Final, Protocol, get_args, runtime_checkable

from actorswarm.runtime.events import Emitted, Scope

__all__ = [
    "VEHICLE_FAULT_EVENT",
    "Camera",
    "CameraUnavailable",
    "Collective",
    "CollectiveUnavailable",
    "Detection",
    "NullCollective",
    "PluginContext",
    "Vehicle",
    "VehicleUnavailable",
]

_SCOPES: Final[tuple[Scope, ...]] = get_args(Scope)
#: The local task event a platform raises when a command to its vehicle failed for good (its
#: deadline passed, the autopilot refused it or was never heard), data ``{"reason": ...}``:
#: the one name that real autopilots' adapters, the simulator's faulty autopilots and the
#: checker's warning about a take-off that nobody answers share.
VEHICLE_FAULT_EVENT: Final = "vehicle_fault_event"
_EVENT_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-]*")


@runtime_checkable
class Vehicle(Protocol):
    """The vehicle interface: what a plugin may ask of the platform it runs on.

    The simulated world implements it, and so does each adapter to a real autopilot
    (MAVLink, ...); a plugin written against it runs on both. Positions are metres in the
    mission's local frame (x east, y north, z up, from the mission origin); each adapter
    converts from its own frame.

    Commands set a goal and return at once — they never wait for the vehicle to get there;
    a plugin watches :meth:`position` over the following steps. A new command replaces the
    previous goal. Reads return the latest known state and never block either.

    **The latest command wins.** A command replaces everything the previous one asked for,
    including what the vehicle has not carried out yet (a mode change still on its way to
    an autopilot): an adapter must never let an earlier command land after a later one. The
    runtime orders an actor switch so that this is enough: the outgoing actor's plugins are
    paused (or stopped) before the incoming actor's start, so whatever the outgoing actor
    commanded last (a hold on arrival) comes before the incoming actor's first goal, and
    the incoming actor's goal is what the vehicle flies.
    """

    def position(self) -> tuple[float, float, float]:
        """Where the vehicle is: ``(x, y, z)`` metres."""
        ...

    def velocity(self) -> tuple[float, float, float]:
        """How fast it moves: ``(vx, vy, vz)`` metres per second."""
        ...

    def battery(self) -> float:
        """The charge left, from 0 (empty) to 1 (full)."""
        ...

    def goto(self, x: float, y: float, z: float, *, speed: float | None = None) -> None:
        """Fly to ``(x, y, z)``, at ``speed`` m/s (None: the vehicle's cruise speed)."""
        ...

    def hold(self) -> None:
        """Stop and hold the current position (a fixed-wing circles it)."""
        ...

    def land(self) -> None:
        """Land where it is."""
        ...

    def takeoff(self, altitude: float) -> None:
        """Take off and climb to ``altitude`` metres above the ground."""
        ...


@dataclass(frozen=True, slots=True)
class Detection:
    """One target a :class:`Camera` sees now.

    ``name`` identifies the target (the same name from one frame to the next, so a tracker
    can keep to one); ``kind`` says what it is (``"jeep"``); ``position`` is where it is,
    ``(x, y, z)`` metres in the mission frame (a real detector geolocates it); ``distance``
    is the straight-line distance from the camera to it, metres.
    """

    name: str
    kind: str
    position: tuple[float, float, float]
    distance: float


@runtime_checkable
class Camera(Protocol):
    """A platform's target detector: what it sees now. Reads never block."""

    def detections(self) -> list[Detection]:
        """The targets in view now, nearest first (empty when none is, or the camera cannot
        see: on the ground, too low)."""
        ...

    def footprint(self) -> float:
        """The radius, metres, of the disc of ground the camera sees now (0 when it sees
        nothing). A search plugin spaces its sweeps by it."""
        ...


@runtime_checkable
class Collective(Protocol):
    """The swarm coordination primitives a plugin may use, wired by the runtime to the
    platform's core node (docs/design.md §3.4). Each call queues a request and returns at once;
    the master answers later, through the core's events.
    """

    def barrier(
        self,
        key: int,
        need: int,
        *,
        bid: float | None = None,
        data: Any = None,
        renew: bool = False,
    ) -> int:
        """Ask to pass barrier ``key`` together with ``need`` platforms (lower ``bid`` wins
        a place; None: the platform ID), attaching ``data`` to gather. Returns the
        generation asked for. A request for a generation that fired before it reached the
        master is answered ``"outcome": "stale"`` (ask again to take part in the next);
        with ``renew`` the master may count it for the open generation instead, when it
        alone fires that one (docs/collective-core.md, "Renewable requests")."""
        ...

    def claim_role(self, role: str, quota: int, *, bid: float | None = None) -> None:
        """Claim ``role``, which at most ``quota`` platforms hold at once (lower ``bid``
        wins; None: the platform ID)."""
        ...

    def release_role(self, role: str) -> None:
        """Give ``role`` up (nothing happens if this platform does not hold it)."""
        ...


class CollectiveUnavailable(RuntimeError):
    """A plugin used ``ctx.collective`` where there is no swarm behind it."""


class VehicleUnavailable(RuntimeError):
    """A plugin asked for the vehicle on a platform (or in a run) that has none."""


class CameraUnavailable(RuntimeError):
    """A plugin asked for the camera on a platform (or in a run) that has none."""


class NullCollective:
    """A :class:`Collective` for contexts without a swarm (unit tests, tools): every call
    raises :class:`CollectiveUnavailable` saying so. Give :func:`actorswarm.testing.
    make_context` a collective of your own to test a plugin that coordinates."""

    __slots__ = ()

    def _refuse(self, what: str) -> CollectiveUnavailable:
        return CollectiveUnavailable(
            f"{what}: this plugin context has no swarm behind it (the plugin runs outside "
            "the actor runtime, e.g. in a unit test); pass collective=... to make_context "
            "to give it one"
        )

    def barrier(
        self,
        key: int,
        need: int,
        *,
        bid: float | None = None,
        data: Any = None,
        renew: bool = False,
    ) -> int:
        raise self._refuse(f"barrier({key}, {need})")

    def claim_role(self, role: str, quota: int, *, bid: float | None = None) -> None:
        raise self._refuse(f"claim_role({role!r}, {quota})")

    def release_role(self, role: str) -> None:
        raise self._refuse(f"release_role({role!r})")


class PluginContext:
    """Everything a plugin's hooks may use; built by the runtime (or, in tests, by
    :func:`actorswarm.testing.make_context`).

    ``now``
        The time in seconds, set by the host before each call (virtual or wall time).
    ``task_start``
        When the task started, on the clock of ``now``: the same instant on every platform
        (the ground station's ``start``, on the clock the platforms share — GPS or NTP time
        on robots, the one clock in the simulator), so ``now - task_start`` is the task's
        time, alike across the swarm. None where the host knows of no start (a unit test).
    ``platform``
        This platform's ID.
    ``actor``
        The name of the actor the plugin belongs to.
    ``params``
        This plugin's validated params (see :meth:`~actorswarm.runtime.plugin.Plugin.
        bind_params`): the script's values with the switching transition's on top. Every
        declared key is present. Read-only by convention.
    ``index``, ``size``
        The actor's 1-based index in the group firing that switched it in, in bid order,
        and the number of platforms that firing chose (both 0: it was not switched in by a
        group).
    ``slot``, ``slots``
        The same within the branch this platform went to: its 1-based place among the
        platforms the firing sent to this actor, and how many it sent (``slot == index``
        and ``slots == size`` for a transition without branches; 0 without a group). A
        formation or a search splits its work by these.
    ``data``
        The data the master scattered to it.
    ``blackboard``
        A dict shared by every plugin of this actor instance.
    ``vehicle``
        The platform's :class:`Vehicle`, or None without one.
    ``camera``
        The platform's :class:`Camera`, or None without one.
    ``areas``
        The mission's named areas: name → polygon (``(x, y)`` vertices, metres).
    ``collective``
        The swarm primitives (:class:`Collective`).
    ``rng``
        The seeded random generator to draw from (never the global ``random``).
    ``ros2``
        The platform's ROS 2 node (:class:`actorswarm.ros2.platform.PlatformRos`), or None
        on a platform without one.
    """

    __slots__ = (
        "_emitted",
        "actor",
        "areas",
        "blackboard",
        "camera",
        "collective",
        "data",
        "index",
        "now",
        "params",
        "platform",
        "rng",
        "ros2",
        "size",
        "slot",
        "slots",
        "task_start",
        "vehicle",
    )

    def __init__(
        self,
        *,
        now: float,
        platform: int,
        actor: str,
        params: Mapping[str, Any] | None = None,
        blackboard: dict[str, Any] | None = None,
        vehicle: Vehicle | None = None,
        collective: Collective | None = None,
        rng: random.Random | None = None,
        index: int = 0,
        data: Any = None,
        size: int = 0,
        slot: int = 0,
        slots: int = 0,
        camera: Camera | None = None,
        areas: Mapping[str, Sequence[tuple[float, float]]] | None = None,
        ros2: Any = None,
        task_start: float | None = None,
    ) -> None:
        self.now = now
        self.task_start = task_start
        self.platform = platform
        self.actor = actor
        self.params: Mapping[str, Any] = dict(params or {})
        self.blackboard: dict[str, Any] = {} if blackboard is None else blackboard
        self.vehicle = vehicle
        self.collective: Collective = NullCollective() if collective is None else collective
        # Seeded by platform, so two platforms of one test do not draw the same numbers.
        self.rng = random.Random(platform) if rng is None else rng
        self.index = index
        self.size = size
        self.slot = slot
        self.slots = slots
        self.data = data
        self.camera = camera
        self.areas: Mapping[str, Sequence[tuple[float, float]]] = dict(areas or {})
        self.ros2 = ros2
        self._emitted: list[Emitted] = []

    def __repr__(self) -> str:
        return (
            f"PluginContext(now={self.now!r}, platform={self.platform!r}, "
            f"actor={self.actor!r}, params={dict(self.params)!r}, "
            f"vehicle={type(self.vehicle).__name__ if self.vehicle else None}, "
            f"pending={len(self._emitted)})"
        )

    def emit(
        self, event: str, *, scope: Scope = "local", bid: float | None = None, data: Any = None
    ) -> None:
        """Emit ``event``: with scope ``local`` only this platform becomes a candidate for
        the transition it names; with ``swarm``, every platform whose actor has one. ``bid``
        ranks this platform when there are more candidates than places (lower wins; None:
        the platform ID); ``data`` is gathered by the master and scattered on release, so
        keep it small plain data. The event leaves after the hook returns.
        """
        if not isinstance(event, str) or not _EVENT_NAME.fullmatch(event):
            raise ValueError(
                f"emit: the event name {event!r} is not valid: use letters, digits, '_', '.' "
                "or '-', starting with a letter or '_'"
            )
        if scope not in _SCOPES:
            raise ValueError(f'emit({event!r}): scope must be "local" or "swarm", not {scope!r}')
        if bid is not None and (
            isinstance(bid, bool) or not isinstance(bid, int | float) or not math.isfinite(bid)
        ):
            raise ValueError(f"emit({event!r}): bid must be a finite number or None, not {bid!r}")
        self._emitted.append(
            Emitted(
                event=event,
                scope=scope,
                bid=None if bid is None else float(bid),
                data=data,
                actor=self.actor,
            )
        )

    @property
    def emitted(self) -> tuple[Emitted, ...]:
        """The events emitted and not yet drained, oldest first."""
        return tuple(self._emitted)

    def drain(self) -> list[Emitted]:
        """Hand over the events emitted so far (oldest first) and forget them; the host calls
        this after each hook."""
        out, self._emitted = self._emitted, []
        return out

    def require_vehicle(self) -> Vehicle:
        """``vehicle``, or :class:`VehicleUnavailable` saying the plugin needs one (declare
        ``needs_vehicle = True`` so the runtime refuses such a start up front)."""
        if self.vehicle is None:
            raise VehicleUnavailable(
                f"actor {self.actor!r} on platform {self.platform}: this plugin needs a "
                "vehicle, and the platform has none (or the run has no world)"
            )
        return self.vehicle

    def require_camera(self) -> Camera:
        """``camera``, or :class:`CameraUnavailable` saying the plugin needs one."""
        if self.camera is None:
            raise CameraUnavailable(
                f"actor {self.actor!r} on platform {self.platform}: this plugin needs a "
                "camera, and the platform has none (or the run has no world)"
            )
        return self.camera
