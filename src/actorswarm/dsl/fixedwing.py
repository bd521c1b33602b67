"""What a fixed-wing cannot fly, known before it flies: warnings from the script and its world.

A fixed-wing never stops in the air: it circles a goal at its loiter radius, holds a moving
slot only by chasing a point ahead of it, and flies only within its airspeed envelope. With
a world whose platforms are fixed-wings, ``actorswarm task check --world WORLD`` (and
``actorswarm sim``) warn, at the script's line, about:

* a formation whose leader's ``speed`` is outside the aircraft's ``[min_airspeed,
  max_speed]`` (below the stall speed, the slots run away from it);
* a formation whose carrot (``lookahead`` seconds of the leader's flight ahead of a slot)
  is within three loiter radii: the aircraft starts circling the carrot instead of flying
  at it, and weaves about its slot;
* a ``flight.goto`` or ``flight.return_home`` whose ``tolerance`` is below the loiter
  radius: the aircraft circles the point at that radius and may never come within the
  tolerance, so the event never comes; a ``flight.goto`` ``speed`` outside the envelope.

Warnings, as :mod:`~actorswarm.dsl.safety`'s: the script may be meant for other aircraft.
The figures are the world's ``[fixed_wing]``, by default ArduPlane 4.5.7's as measured (a
goal circled at ~50 m; a real ArduPlane told to hold circles at ~100 m: docs/vehicles.md,
"Fixed-wing").
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

from actorswarm.dsl.diagnostics import Report
from actorswarm.dsl.model import Param, PluginSpec, TaskScript
from actorswarm.dsl.plugins import plugin_class
from actorswarm.dsl.safety import position_of

if TYPE_CHECKING:
    from actorswarm.world.config import FixedWingParams, WorldConfig

__all__ = ["check_fixed_wing"]

#: A carrot closer than this many loiter radii is circled rather than chased (the guidance
#: field blends into the loiter circle from there; ArduPlane's L1 likewise).
CARROT_RADII = 3.0


def check_fixed_wing(script: TaskScript, world: WorldConfig, report: Report) -> None:
    """Warn on ``report`` about what the module docstring names, when any of ``script``'s
    platforms is a fixed-wing in ``world``."""
    platforms = script.platform_ids()
    if not platforms or not any(s.kind == "fixed_wing" for s in world.vehicle_specs(platforms)):
        return
    aircraft = world.fixed_wing
    for actor in script.actors:
        for specs in actor.buses.values():
            for spec in specs:
                params = {p.key: p for p in spec.params}
                if spec.name.startswith("formation."):
                    _formation(spec, params, aircraft, report)
                elif spec.name in ("flight.goto", "flight.return_home"):
                    _arrival(spec, params, aircraft, report)


def _default(spec: PluginSpec, key: str) -> float | None:
    """The plugin's own default of ``key`` (None: it has none, or no such plugin)."""
    cls = plugin_class(spec.name)
    param = None if cls is None else cls.params.get(key)
    value = None if param is None else param.default
    return float(value) if isinstance(value, int | float) else None


def _number(spec: PluginSpec, params: Mapping[str, Param], key: str) -> float | None:
    param = params.get(key)
    if param is None:
        return _default(spec, key)
    try:
        return float(param.value)
    except ValueError:
        return None  # the checker has said what is wrong with it


def _envelope(
    spec: PluginSpec,
    params: Mapping[str, Param],
    key: str,
    aircraft: FixedWingParams,
    report: Report,
) -> None:
    speed = _number(spec, params, key)  # the plugin's default when left out
    if speed is None:
        return
    low, high = aircraft.min_airspeed, aircraft.max_speed
    if speed < low:
        report.warning(
            position_of(spec, params.get(key)),
            f"{spec.name}: {key} {speed:g} m/s is below the fixed-wings' min_airspeed "
            f"({low:g} m/s in the world): they cannot fly that slowly (the stall speed)",
        )
    elif speed > high:
        report.warning(
            position_of(spec, params.get(key)),
            f"{spec.name}: {key} {speed:g} m/s is above the fixed-wings' max_speed "
            f"({high:g} m/s in the world)",
        )


def _formation(
    spec: PluginSpec, params: Mapping[str, Param], aircraft: FixedWingParams, report: Report
) -> None:
    _envelope(spec, params, "speed", aircraft, report)
    speed, lookahead = _number(spec, params, "speed"), _number(spec, params, "lookahead")
    if speed is None or lookahead is None or speed <= 0:
        return
    carrot, reach = speed * lookahead, CARROT_RADII * aircraft.loiter_radius
    if carrot < reach:
        report.warning(
            position_of(spec, params.get("lookahead")),
            f"{spec.name}: the carrot is {carrot:g} m ahead of each slot (lookahead "
            f"{lookahead:g} s × speed {speed:g} m/s), within {CARROT_RADII:g} loiter radii "
            f"({reach:g} m in the world): a fixed-wing would circle it rather than fly at it; "
            f"make lookahead at least {reach / speed:.3g}",
        )


def _arrival(
    spec: PluginSpec, params: Mapping[str, Param], aircraft: FixedWingParams, report: Report
) -> None:
    if spec.name == "flight.goto":
        _envelope(spec, params, "speed", aircraft, report)
    tolerance = _number(spec, params, "tolerance")
    radius = aircraft.loiter_radius
    if tolerance is not None and tolerance < radius:
        report.warning(
            position_of(spec, params.get("tolerance")),
            f"{spec.name}: tolerance {tolerance:g} m is below the fixed-wings' loiter radius "
            f"({radius:g} m in the world): an aircraft circles its goal at that radius and "
            f"may never come within the tolerance; make it at least {radius:g}",
        )
