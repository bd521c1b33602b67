"""Whether a simulated run went as asked, and the exit status of ``actorswarm sim`` that
says so.

Two moments:

* **Before the run**, :func:`schedule_problems` reads the command line's schedule against
  the script: a ground-station event that no transition of any actor handles (it would be
  ignored on every platform, with a suggestion when a handled name is close), an event or a
  fault set after the end of the run (it would never happen), a platform the script does not
  start. Each is a mistake in the command, refused before anything runs
  (:data:`EXIT_USAGE`).
* **After the run**, :func:`verdict` reads the report: an invariant violated or two
  airborne vehicles closer than their separation (:data:`EXIT_VIOLATION`), a plugin that
  failed (:data:`EXIT_PLUGIN_FAILED`), and, when the caller expects it, a task that did
  not complete (:data:`EXIT_INCOMPLETE`). When several went wrong, the status is the
  first of those in that order; every one is said.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any, Final

from actorswarm.dsl.model import TaskScript
from actorswarm.dsl.syntax import id_ranges
from actorswarm.sim.tasksim import Fault, GroundEvent
from actorswarm.sim.vehicle_faults import VehicleFault
from actorswarm.suggest import did_you_mean
from actorswarm.world.separation import BREACH_PREFIX

#: The run went as asked.
EXIT_OK: Final = 0
#: An invariant of the collective core was violated, or a separation breached (also: the
#: script has errors).
EXIT_VIOLATION: Final = 1
#: The command line cannot be run as written: an option, the world file, or the schedule.
EXIT_USAGE: Final = 2
#: A plugin failed during the run (its actor went to its error state).
EXIT_PLUGIN_FAILED: Final = 3
#: ``--expect-complete`` was given and the task did not complete.
EXIT_INCOMPLETE: Final = 4


def schedule_problems(
    script: TaskScript,
    duration: float,
    events: Iterable[GroundEvent] = (),
    faults: Iterable[Fault] = (),
    vehicle_faults: Iterable[VehicleFault] = (),
) -> list[str]:
    """Every mistake in the schedule of a run of ``script`` for ``duration`` seconds, one
    sentence each (empty: none)."""
    handled = sorted({t.event for t in script.all_transitions()})
    platforms = script.platform_ids()
    problems: list[str] = []
    for event in events:
        flag = f"--event {event.name}@{event.t:g}"
        if event.name not in handled:
            listing = ", ".join(handled) if handled else "none"
            problems.append(
                f"{flag}: no transition of any actor is on {event.name}"
                f"{did_you_mean(event.name, handled)}, so every platform would ignore it "
                f"(the events the script handles: {listing})"
            )
        problems += _after(flag, event.t, duration)
        if event.ids is not None:
            problems += _unknown(flag, event.ids, platforms)
    for fault in faults:
        flag = " ".join(fault.option())
        problems += _after(flag, fault.t, duration)
        problems += _unknown(flag, fault.ids, platforms)
    for vf in vehicle_faults:
        flag = " ".join(vf.option())
        if vf.kind == "late":
            problems += _after(flag, vf.value, duration)
        problems += _unknown(flag, vf.ids, platforms)
    return problems


def _after(flag: str, t: float, duration: float) -> list[str]:
    if t <= duration:
        return []
    return [
        f"{flag}: {t:g} s is after the end of the run (--duration {duration:g}), so it would "
        "never happen; make the run longer or the time earlier"
    ]


def _unknown(flag: str, ids: frozenset[int], platforms: frozenset[int]) -> list[str]:
    missing = ids - platforms
    if not missing:
        return []
    which = "platform" if len(missing) == 1 else "platforms"
    return [
        f"{flag}: the script starts no {which} {id_ranges(frozenset(missing))} (its platforms: "
        f"{id_ranges(platforms)})"
    ]


def verdict(report: Mapping[str, Any], *, expect_complete: bool = False) -> tuple[int, list[str]]:
    """The exit status of a finished run's ``report`` and what went wrong, one line each
    (no line when the status is :data:`EXIT_OK`)."""
    found: list[tuple[int, str]] = []
    breaches = sum(1 for v in report["violations"] if v.startswith(BREACH_PREFIX))
    invariants = len(report["violations"]) - breaches
    if invariants:
        found.append((EXIT_VIOLATION, f"{invariants} invariant(s) violated"))
    if breaches:
        separation = report.get("separation") or {}
        count = len(separation.get("breaches", ())) or breaches
        halted = " (fatal: the run stopped at the first)" if report.get("halted") else ""
        found.append((EXIT_VIOLATION, f"{count} separation breach(es){halted}"))
    if report["plugin_failures"]:
        count = len(report["plugin_failures"])
        found.append((EXIT_PLUGIN_FAILED, f"{count} plugin failure(s)"))
    if expect_complete and not report["completed"]:
        found.append(
            (
                EXIT_INCOMPLETE,
                f"the task did not complete in {report['sim_time_s']:g} s (not every platform "
                "ended in an actor without transitions; see final:)",
            )
        )
    if not found:
        return EXIT_OK, []
    status = found[0][0]
    return status, [f"run failed (exit {status}): " + "; ".join(text for _, text in found)]
