"""Autopilots that misbehave in the simulator, as real ones do: ready late, refusing to
take off, a battery that drains faster.

A real autopilot refuses to arm until its estimator has aligned (tens of seconds after
boot, longer with a poor GPS fix), may refuse for good (a failed pre-arm check), and a worn
battery empties sooner than the world's endurance says. The daemon's MAVLink vehicle turns
these into a take-off that waits (the ARM persists until the autopilot accepts it) or, at
its ``arm_timeout``, into the task event ``vehicle_fault_event``. :class:`FaultyVehicle`
gives a simulated vehicle the same behaviour, so a task script's answer to them can be tried
(``actorswarm sim --late-ready / --refuse-takeoff / --drain``, and ``task verify``).

Only commands that would take the vehicle off the ground are gated (``takeoff``, and a
``goto`` from the ground, which takes off); everything else passes straight through.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Final, Literal

from actorswarm.runtime.context import VEHICLE_FAULT_EVENT
from actorswarm.world.vehicles import SimVehicle

__all__ = [
    "REFUSE_AFTER_S",
    "VEHICLE_FAULT_EVENT",
    "FaultyVehicle",
    "VehicleFault",
    "parse_vehicle_fault",
]

#: The task event a vehicle raises when a command fails for good (the daemon's name).
#: How long a refused take-off is retried before it fails for good: the MAVLink vehicle's
#: default ``arm_timeout``, so the script hears of it when it would in the field.
REFUSE_AFTER_S: Final = 120.0

VehicleFaultKind = Literal["late", "refuse", "drain"]


@dataclass(frozen=True, slots=True)
class VehicleFault:
    """One misbehaving autopilot on the platforms ``ids``.

    ``late``: not ready to take off before ``value`` seconds (a take-off asked earlier
    waits, then goes); ``refuse``: never ready (each take-off fails for good
    :data:`REFUSE_AFTER_S` after it was asked, raising :data:`VEHICLE_FAULT_EVENT`);
    ``drain``: the battery drains ``value`` times faster than the world's endurance says.
    """

    kind: VehicleFaultKind
    ids: frozenset[int]
    value: float = 0.0

    def option(self) -> list[str]:
        """The ``actorswarm sim`` options that give this fault."""
        from actorswarm.dsl.syntax import id_ranges

        ids = id_ranges(self.ids)
        if self.kind == "late":
            return ["--late-ready", f"{ids}@{self.value:.12g}"]
        if self.kind == "refuse":
            return ["--refuse-takeoff", ids]
        return ["--drain", f"{ids}:{self.value:.12g}"]


def parse_vehicle_fault(kind: VehicleFaultKind, text: str) -> VehicleFault:
    """``--late-ready IDS@T``, ``--refuse-takeoff IDS``, ``--drain IDS:FACTOR``; ValueError
    with the option's name and an example when ``text`` is not one."""
    from actorswarm.dsl.syntax import platform_ids

    flag, example, sep = {
        "late": ("--late-ready", "3@40", "@"),
        "refuse": ("--refuse-takeoff", "3,5", ""),
        "drain": ("--drain", "3:4", ":"),
    }[kind]
    ids_text, found, rest = text.partition(sep) if sep else (text, "", "")
    if sep and not found:
        raise ValueError(f"{flag}: expected {example.replace('3', 'IDS', 1)} such as {example}")
    try:
        ids = platform_ids(ids_text)
    except ValueError as exc:
        raise ValueError(f"{flag}: {exc}") from None
    if kind == "refuse":
        return VehicleFault(kind, ids)
    try:
        value = float(rest)
    except ValueError:
        raise ValueError(f"{flag}: {rest!r} is not a number (such as {example})") from None
    if kind == "late" and not 0 <= value < 1e9:
        raise ValueError(f"{flag}: the time must be >= 0 seconds, got {rest!r}")
    if kind == "drain" and not 1.0 <= value <= 1000.0:
        raise ValueError(f"{flag}: the factor must be 1..1000 (times faster), got {rest!r}")
    return VehicleFault(kind, ids, value)


class FaultyVehicle:
    """A :class:`SimVehicle` whose autopilot is ready only from ``ready_at`` (``late``) or
    never (``refuses``).

    While not ready, a command that would take the vehicle off the ground is held: the
    latest one goes out at ``ready_at`` (``schedule(t, fn)`` runs ``fn`` then); a refusing
    autopilot keeps it for :data:`REFUSE_AFTER_S` and then calls ``fault(reason)`` (the
    host raises :data:`VEHICLE_FAULT_EVENT`), once per refused command. A ``land`` or
    ``hold`` meanwhile drops the held command, as it would cancel a take-off in progress.
    Every other attribute is the wrapped vehicle's.
    """

    def __init__(
        self,
        inner: SimVehicle,
        *,
        clock: Callable[[], float],
        schedule: Callable[[float, Callable[[], None]], object],
        fault: Callable[[str], None],
        ready_at: float = 0.0,
        refuses: bool = False,
    ) -> None:
        self._inner = inner
        self._clock = clock
        self._schedule = schedule
        self._fault = fault
        self._ready_at = ready_at
        self._refuses = refuses
        self._held: Callable[[], None] | None = None
        self._waiting = False  # a release (or a refusal) is scheduled
        self._asks = 0  # refused commands so far: a stale refusal timer is ignored

    def __getattr__(self, name: str) -> Any:
        return getattr(self._inner, name)

    def __repr__(self) -> str:
        return f"FaultyVehicle({self._inner!r}, ready_at={self._ready_at}, refuses={self._refuses})"

    # --- the Vehicle interface -------------------------------------------------------------------

    def position(self) -> tuple[float, float, float]:
        return self._inner.position()

    def velocity(self) -> tuple[float, float, float]:
        return self._inner.velocity()

    def battery(self) -> float:
        return self._inner.battery()

    def goto(self, x: float, y: float, z: float, *, speed: float | None = None) -> None:
        self._gate(lambda: self._inner.goto(x, y, z, speed=speed))

    def takeoff(self, altitude: float) -> None:
        self._gate(lambda: self._inner.takeoff(altitude))

    def hold(self) -> None:
        self._held = None
        self._inner.hold()

    def land(self) -> None:
        self._held = None
        self._inner.land()

    # --- the fault -------------------------------------------------------------------------------

    def _on_ground(self) -> bool:
        return self._inner.mode in ("ground", "landed")

    def _gate(self, command: Callable[[], None]) -> None:
        now = self._clock()
        if not self._on_ground() or (not self._refuses and now >= self._ready_at):
            command()
            return
        first = self._held is None
        self._held = command
        if self._refuses:
            if first:
                self._asks += 1
                ask = self._asks
                self._schedule(now + REFUSE_AFTER_S, lambda: self._refused(ask))
        elif not self._waiting:
            self._waiting = True
            self._schedule(self._ready_at, self._release)

    def _release(self) -> None:
        self._waiting = False
        held, self._held = self._held, None
        if held is not None:
            held()

    def _refused(self, ask: int) -> None:
        if ask != self._asks or self._held is None:
            return  # cancelled by a land/hold, or superseded
        self._held = None
        self._fault(
            f"take-off refused: the autopilot did not arm within {REFUSE_AFTER_S:.12g} s "
            "(simulated pre-arm failure)"
        )
