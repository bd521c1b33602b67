"""What can be known about separation and altitude before a script flies, from its world.

``actorswarm task check --world WORLD`` (and ``actorswarm sim``, which always has a world)
read the script against the world it will fly in and warn, at the script's line, about:

* a formation whose ``spacing`` is below the separation of the vehicles that fly it (the
  slots themselves would breach it);
* a formation asked of more platforms than its ``size`` gives slots;
* a ``flight.goto`` a group is sent to with no ``spacing`` (every member to one point), or
  a ``spacing`` below the separation;
* an altitude above the world's ``[safety] ceiling``: a plugin's ``altitude`` (a formation's
  top layer, ``altitude + (size - 1) · altitude_step``; the way home's, ``altitude +
  (layers - 1) · layer_step``), a ``target`` or ``TargetPoint``;
* a formation's transit layers (``transit_step`` apart, half below its ``altitude`` and
  half above, ``transit_layers`` of them, 0 being one per member) reaching the ground or
  above the ceiling;
* a named area too small for the platforms that may be sent there: fewer than one square of
  the separation's side for each.

They are warnings, not errors: the script is valid and may be meant for another world.
The number of platforms that may hold an actor is an upper bound read from the script (the
platforms starting it, plus each transition's ``sysNum`` into it, at most every platform),
and the separation is the largest of the kinds the script's platforms fly in the world.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING

from actorswarm.dsl.diagnostics import Report
from actorswarm.dsl.model import NOWHERE, Param, PluginSpec, Position, TaskScript

if TYPE_CHECKING:
    from actorswarm.world.config import WorldConfig

__all__ = ["check_safety", "position_of"]

#: A formation's params' defaults, as the formation plugins have them.
_SPACING_DEFAULT = 20.0
_ALTITUDE_DEFAULT = 30.0


def check_safety(script: TaskScript, world: WorldConfig, report: Report) -> None:
    """Warn on ``report`` about everything of the module docstring ``script`` does in
    ``world``."""
    platforms = script.platform_ids()
    if not platforms:
        return
    kinds = {spec.kind for spec in world.vehicle_specs(platforms)}
    minimums = world.separations()
    separation = max(minimums[k] for k in kinds)
    what = " and ".join(f"{k} {minimums[k]:g} m" for k in sorted(kinds))
    holders = _holders(script, len(platforms))
    started = {line.actor: 0 for line in script.platforms}
    for line in script.platforms:
        started[line.actor] += len(line.ids)
    ceiling = world.safety.ceiling
    for actor in script.actors:
        count = holders.get(actor.name, 0)
        for specs in actor.buses.values():
            for spec in specs:
                params = {p.key: p for p in spec.params}
                if spec.name.startswith("formation."):
                    _formation(spec, params, count, separation, what, ceiling, report)
                elif spec.name == "flight.goto":
                    sent = count - started.get(actor.name, 0)
                    _goto(spec, params, (sent, count), separation, what, ceiling, report)
                elif spec.name == "flight.return_home":
                    _return_home(spec, params, count, ceiling, report)
                else:
                    _altitude(spec, params, ceiling, report)
                if "area" in params:
                    _area(params["area"], world, count, separation, what, report)
    if ceiling > 0:
        for transition in script.all_transitions():
            for param in transition.params:
                if param.key == "TargetPoint":
                    _point(param, ceiling, report)


def _holders(script: TaskScript, total: int) -> dict[str, int]:
    """How many platforms may hold each actor (an upper bound, at most ``total``)."""
    out: dict[str, int] = {}
    for line in script.platforms:
        out[line.actor] = out.get(line.actor, 0) + len(line.ids)
    for transition in script.all_transitions():
        sent = total if transition.sys_num == "all" else int(transition.sys_num)
        for branch in transition.branches:
            share = sent if not isinstance(branch.count, int) else min(sent, branch.count)
            out[branch.successor] = out.get(branch.successor, 0) + share
    return {actor: min(n, total) for actor, n in out.items()}


def _number(param: Param | None, default: float) -> float | None:
    if param is None:
        return default
    try:
        value = float(param.value)
    except ValueError:
        return None  # the checker has said what is wrong with it
    return value if math.isfinite(value) else None


def position_of(spec: PluginSpec, param: Param | None) -> Position:
    """Where a warning about ``param`` of ``spec`` points: the param's line, else the
    plugin's (a param left out)."""
    return param.pos if param is not None and param.pos != NOWHERE else spec.pos


def _formation(
    spec: PluginSpec,
    params: Mapping[str, Param],
    count: int,
    separation: float,
    what: str,
    ceiling: float,
    report: Report,
) -> None:
    spacing = _number(params.get("spacing"), _SPACING_DEFAULT)
    if spacing is not None and spacing < separation:
        report.warning(
            position_of(spec, params.get("spacing")),
            f"{spec.name}: spacing {spacing:g} m is below the vehicles' separation ({what} "
            f"in the world): neighbouring slots would breach it; make spacing at least "
            f"{separation:g}",
        )
    size = _number(params.get("size"), 0.0)
    if size is not None and size > 0 and count > size:
        report.warning(
            position_of(spec, params.get("size")),
            f"{spec.name}: size {size:g} gives {size:g} slots but up to {count} platforms may "
            "fly this formation; those beyond the slots will refuse to start (size 0 gives "
            "one slot per platform sent)",
        )
    _transit_layers(spec, params, int(size) if size else count, ceiling, report)
    if ceiling > 0:
        altitude = _number(params.get("altitude"), _ALTITUDE_DEFAULT)
        step = _number(params.get("altitude_step"), 0.0)
        slots = int(size) if size else count
        if altitude is not None and step is not None:
            top = altitude + max(slots - 1, 0) * step
            if top > ceiling:
                report.warning(
                    position_of(spec, params.get("altitude_step") or params.get("altitude")),
                    f"{spec.name}: its top layer is at {top:g} m (altitude {altitude:g} + "
                    f"{max(slots - 1, 0)} × altitude_step {step:g}), above the world's "
                    f"ceiling of {ceiling:g} m ([safety] ceiling)",
                )


def _transit_layers(
    spec: PluginSpec, params: Mapping[str, Param], members: int, ceiling: float, report: Report
) -> None:
    """The lowest and highest of a formation's transit layers, as the plugin lays them out
    for ``members`` (its ``_transit``): the lowest on or under the ground, the highest
    above a ceiling, are warned about."""
    from actorswarm.plugins.flight import TRANSIT_LAYERS
    from actorswarm.plugins.formation import transit_altitude

    step = _number(params.get("transit_step"), 0.0)
    altitude = _number(params.get("altitude"), _ALTITUDE_DEFAULT)
    layers = _number(params.get("transit_layers"), float(TRANSIT_LAYERS))
    if step is None or altitude is None or layers is None or step <= 0 or members < 1:
        return
    used = int(layers) or members
    lowest = transit_altitude(altitude, 0, used, step)
    highest = transit_altitude(altitude, used - 1, used, step)
    where = position_of(spec, params.get("transit_layers") or params.get("transit_step"))
    said = f"{used} transit layers" + (f" (one per member, {members})" if not int(layers) else "")
    if lowest <= 0:
        report.warning(
            where,
            f"{spec.name}: its lowest transit layer is at {lowest:g} m, on or under the "
            f"ground ({said}, {step:g} m apart, half of them below altitude {altitude:g}); "
            "give fewer transit_layers, a smaller transit_step or a higher altitude",
        )
    if ceiling > 0 and highest > ceiling:
        report.warning(
            where,
            f"{spec.name}: its highest transit layer is at {highest:g} m ({said}, "
            f"{step:g} m apart, half of them above altitude {altitude:g}), above the world's "
            f"ceiling of {ceiling:g} m ([safety] ceiling)",
        )


def _goto(
    spec: PluginSpec,
    params: Mapping[str, Param],
    counts: tuple[int, int],
    separation: float,
    what: str,
    ceiling: float,
    report: Report,
) -> None:
    """``counts``: the platforms a transition may send here (spacing spreads those), and
    all that may hold the actor."""
    sent, count = counts
    spacing = _number(params.get("spacing"), 0.0)
    if sent > 1 and spacing is not None and spacing < separation:
        said = "no spacing" if spacing == 0 else f"spacing {spacing:g} m"
        report.warning(
            position_of(spec, params.get("spacing")),
            f"flight.goto: up to {sent} platforms may be sent here with {said}: they would "
            f"meet closer than their separation ({what} in the world); give "
            f'<param key="spacing" value="{separation:g}"/> or more',
        )
    elif count > 1 and sent <= 1 and "target" in params:
        report.warning(
            params["target"].pos,
            f"flight.goto: the {count} platforms that start here all fly to this one target "
            f"and would meet closer than their separation ({what} in the world); start them "
            "in an actor of their own each, or send them here with a transition and a spacing",
        )
    if ceiling > 0 and "target" in params:
        _point(params["target"], ceiling, report)


def _return_home(
    spec: PluginSpec, params: Mapping[str, Param], count: int, ceiling: float, report: Report
) -> None:
    """The top of the layers a group of ``count`` goes home on: ``altitude + (layers - 1) ·
    layer_step``, ``layers`` 0 being one per member."""
    _altitude(spec, params, ceiling, report)
    if ceiling <= 0:
        return
    # Imported here, as the checker reads plugins' params: only a script that goes home
    # in a world with a ceiling needs the flight plugins' defaults.
    from actorswarm.plugins.flight import ReturnHome

    def default(key: str) -> float:
        value = ReturnHome.params[key].default
        return float(value) if isinstance(value, int | float) else 0.0

    altitude = _number(params.get("altitude"), default("altitude"))
    step = _number(params.get("layer_step"), 0.0)
    layers = _number(params.get("layers"), default("layers"))
    if altitude is None or step is None or layers is None or step <= 0:
        return
    used = min(int(layers) or count, count)
    top = altitude + max(used - 1, 0) * step
    if top > ceiling and altitude <= ceiling:
        report.warning(
            position_of(spec, params.get("layer_step")),
            f"{spec.name}: the top layer of the way home is at {top:g} m (altitude "
            f"{altitude:g} + {max(used - 1, 0)} × layer_step {step:g}), above the world's "
            f"ceiling of {ceiling:g} m ([safety] ceiling)",
        )


def _altitude(
    spec: PluginSpec, params: Mapping[str, Param], ceiling: float, report: Report
) -> None:
    if ceiling <= 0 or "altitude" not in params:
        return
    altitude = _number(params["altitude"], 0.0)
    if altitude is not None and altitude > ceiling:
        report.warning(
            params["altitude"].pos,
            f"{spec.name}: altitude {altitude:g} m is above the world's ceiling of "
            f"{ceiling:g} m ([safety] ceiling)",
        )


def _point(param: Param, ceiling: float, report: Report) -> None:
    parts = param.value.split()
    if len(parts) != 3:
        return
    z = _number(Param(key=param.key, value=parts[2]), 0.0)
    if z is not None and z > ceiling:
        report.warning(
            param.pos,
            f"{param.key} is at {z:g} m, above the world's ceiling of {ceiling:g} m "
            "([safety] ceiling)",
        )


def _area(
    param: Param, world: WorldConfig, count: int, separation: float, what: str, report: Report
) -> None:
    names = {area.name: area for area in world.areas}
    area = names.get(param.value.strip())
    if area is None or count < 2:
        return
    needed = count * separation * separation
    if area.area < needed:
        report.warning(
            param.pos,
            f"area {area.name!r} ({area.area:,.0f} m²) is too small for the {count} platforms "
            f"that may be sent there: each needs a square of its separation's side ({what}), "
            f"{needed:,.0f} m² in all",
        )
