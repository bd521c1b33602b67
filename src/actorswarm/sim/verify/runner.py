"""One ``task verify`` run: the user's mission under one fault schedule, and what came of it.

A :class:`Mission` carries the script's and the world's *text* (not their paths), so a run
can happen in a worker process or on another machine of a Ray cluster; each process parses
them once (:func:`_loaded`). :func:`run_one` never raises for what the simulation does: an
exception inside the simulator is a result of its own (``crash``, with the traceback), so
one bad run cannot abort the others.
"""

from __future__ import annotations

import functools
import re
import shlex
import time
import traceback
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from actorswarm.core.config import CoreConfig
from actorswarm.dsl.model import TaskScript
from actorswarm.sim.tasksim import Fault, GroundEvent, TaskSim
from actorswarm.sim.verify.schedule import Schedule
from actorswarm.world.config import WorldConfig
from actorswarm.world.separation import BREACH_PREFIX

__all__ = ["Mission", "RunResult", "looping", "run_one", "signature_of"]


@dataclass(frozen=True, slots=True)
class Mission:
    """What every run shares: the script and world (as text, with the paths a replay
    command names), how long to run and the operator's events as planned."""

    script_text: str
    script_path: str
    world_text: str | None
    world_path: str | None
    duration: float
    events: tuple[GroundEvent, ...]
    #: ``sim --no-world``: protocol and plugins only.
    no_world: bool = False
    min_separation: float | None = None
    #: Faults the mission itself has (its ``<?actorswarm sim ...?>`` line), in every run.
    faults: tuple[Fault, ...] = ()
    #: A run completed when every platform ends in one of these actors (``--done``; empty:
    #: in an actor without transitions, as ``sim`` says "completed").
    done: tuple[str, ...] = ()
    #: Those of ``done`` the script starts platforms in and that have transitions (a
    #: mission that loops back): a platform counts as done there only once it has switched
    #: into one of them, so a run that never left its start is not taken for one that came
    #: back.
    came_back: tuple[str, ...] = ()

    def all_faults(self, schedule: Schedule) -> list[Fault]:
        """The mission's faults and ``schedule``'s, in the order ``actorswarm sim`` takes
        them from its command line (by option, each in the order given): faults at the same
        instant then happen in the same order in a run and in its replay."""
        faults = [*self.faults, *schedule.faults()]
        return sorted(faults, key=lambda f: _FAULT_ORDER.index(f.kind))

    def replay(self, schedule: Schedule, *, record: str | None = None) -> str:
        """The one ``actorswarm sim`` command that runs ``schedule`` again, bit for bit."""
        parts = ["actorswarm", "sim", self.script_path]
        if self.no_world:
            parts.append("--no-world")
        elif self.world_path is not None:
            parts += ["--world", _shown(self.world_path)]
        parts += ["--duration", f"{self.duration:g}"]
        if self.min_separation is not None:
            parts += ["--min-separation", f"{self.min_separation:g}"]
        for fault in self.faults:
            parts += fault.option()
        parts += schedule.sim_options()
        if record is not None:
            parts += ["--record", record]
        return shlex.join(parts)


def _shown(path: str) -> str:
    """``path`` relative to the working directory when it lies below it (a shorter
    command), as given otherwise."""
    import os

    absolute = os.path.abspath(path)
    here = os.getcwd()
    return os.path.relpath(absolute, here) if absolute.startswith(here + os.sep) else path


#: The order of ``actorswarm sim``'s fault options.
_FAULT_ORDER = ("kill", "restart", "partition", "heal")


@dataclass(slots=True)
class RunResult:
    """What one run yielded (JSON-ready through :meth:`as_dict`)."""

    seed: int
    completed: bool
    #: When the last platform reached its final actor (None: not completed).
    completion_s: float | None
    #: Why it did not complete, in ``sim``'s words ("" when it did).
    why: str
    violations: list[str]
    breaches: int
    #: The actors the first breaching pair ran then ("B/C"), or "" without a breach.
    breach_actors: str
    #: The closest any two airborne vehicles came, and that pair's required minimum.
    closest_m: float | None
    minimum_m: float | None
    master_changes: int
    packets: int
    plugin_failures: list[str]
    #: The traceback when the simulator itself raised (the run is then a failure).
    crash: str | None
    faults: list[str]
    wall_s: float
    signature: str = field(default="")

    @property
    def ok(self) -> bool:
        return self.signature == ""

    @property
    def margin_m(self) -> float | None:
        """Closest approach minus the minimum it had to keep (negative: a breach)."""
        if self.closest_m is None or self.minimum_m is None:
            return None
        return round(self.closest_m - self.minimum_m, 3)

    def as_dict(self) -> dict[str, Any]:
        return {
            "seed": self.seed,
            "ok": self.ok,
            "signature": self.signature,
            "completed": self.completed,
            "completion_s": self.completion_s,
            "why": self.why,
            "violations": self.violations,
            "breaches": self.breaches,
            "breach_actors": self.breach_actors,
            "closest_m": self.closest_m,
            "minimum_m": self.minimum_m,
            "margin_m": self.margin_m,
            "master_changes": self.master_changes,
            "packets": self.packets,
            "plugin_failures": self.plugin_failures,
            "crash": self.crash,
            "faults": self.faults,
            "wall_s": round(self.wall_s, 3),
        }


@functools.lru_cache(maxsize=8)
def _loaded(script_text: str, world_text: str | None) -> tuple[TaskScript, WorldConfig | None]:
    """The parsed script and world (each process parses a mission once). The caller checked
    both before any run, so a failure here is a bug, reported as a crash."""
    from actorswarm.dsl.checker import check
    from actorswarm.world.config import loads_world

    world = None if world_text is None else loads_world(world_text, source="the world")
    result = check(script_text, world=world)
    if result.script is None:
        raise ValueError(f"the script does not check: {result.errors[0]}")
    return result.script, world


@functools.lru_cache(maxsize=1)
def _default_world() -> WorldConfig:
    """The default world, read once per process (not at every run)."""
    from actorswarm.world.config import load_world

    return load_world(None)


def platforms_of(mission: Mission) -> frozenset[int]:
    """The platforms the mission's script starts."""
    script, _ = _loaded(mission.script_text, None)
    return script.platform_ids()


def build(mission: Mission, schedule: Schedule) -> TaskSim:
    """The simulation of ``schedule`` (not yet run)."""
    script, world = _loaded(mission.script_text, None if mission.no_world else mission.world_text)
    if world is None and not mission.no_world:
        world = _default_world()  # as `sim` without --world
    return TaskSim(
        script,
        seed=schedule.seed,
        link=schedule.link(),
        config=CoreConfig(),
        world_config=world,
        min_separation=mission.min_separation,
        vehicle_faults=schedule.vehicle_faults() if world is not None else (),
    )


def run_one(mission: Mission, schedule: Schedule) -> RunResult:
    """Run ``schedule`` and say what came of it (never raises for the simulation's sake)."""
    began = time.perf_counter()
    faults = [item.text for item in schedule.items]
    try:
        sim = build(mission, schedule)
        report = sim.run(
            mission.duration, events=schedule.ground_events(), faults=mission.all_faults(schedule)
        )
    except Exception:
        crash = traceback.format_exc().rstrip()
        result = RunResult(
            schedule.seed, False, None, "the simulator raised", [], 0, "", None, None, 0, 0,
            [], crash, faults, time.perf_counter() - began,
        )  # fmt: skip
        result.signature = signature_of(result)
        return result
    if mission.done:
        report = _judged_by(report, frozenset(mission.done), frozenset(mission.came_back))
    result = _result(report, schedule.seed, faults, time.perf_counter() - began)
    result.signature = signature_of(result)
    return result


def _result(report: dict[str, Any], seed: int, faults: list[str], wall: float) -> RunResult:
    from actorswarm.sim.tasksim import why_not

    separation = report.get("separation") or {}
    closest = separation.get("closest")
    violations = [v for v in report["violations"] if not v.startswith(BREACH_PREFIX)]
    breaches = len(separation.get("breaches", ())) or (len(report["violations"]) - len(violations))
    completed = bool(report["completed"])
    return RunResult(
        seed=seed,
        completed=completed,
        completion_s=_completion(report) if completed else None,
        why="" if completed else why_not(report),
        violations=violations,
        breaches=breaches,
        breach_actors=_breach_actors(report, separation),
        closest_m=None if closest is None else closest["distance_m"],
        minimum_m=None if closest is None else closest["minimum_m"],
        master_changes=len(report["masters"]),
        packets=sum(int(row.get("sent_packets", 0)) for row in report["traffic"].values()),
        plugin_failures=[
            f"{f['actor']}/{f['plugin']} on {f['platform']}: {f['error']}"
            for f in report["plugin_failures"]
        ],
        crash=None,
        faults=faults,
        wall_s=wall,
    )


def _breach_actors(report: dict[str, Any], separation: dict[str, Any]) -> str:
    """The actors the two platforms of the first breach ran at its start, sorted ("B/C";
    "-" for one that ran none): the phase of the mission where separation was lost."""
    breaches = separation.get("breaches") or []
    if not breaches:
        return ""
    first = min(breaches, key=lambda b: b["start"])
    running: dict[int, str] = {}
    for move in report["transitions"]:  # in time order
        if move["t"] > first["start"]:
            break
        running[move["platform"]] = move["to"]
    return "/".join(sorted(running.get(p) or "-" for p in first["platforms"]))


def looping(script: TaskScript, done: Iterable[str]) -> tuple[str, ...]:
    """Those of the ``done`` actors that ``script`` starts platforms in and that have
    transitions: a mission that loops back to them (:attr:`Mission.came_back`)."""
    started = script.initial_actors()
    return tuple(a for a in done if a in started and a in script.transitions)


def _judged_by(
    report: dict[str, Any], done: frozenset[str], came_back: frozenset[str] = frozenset()
) -> dict[str, Any]:
    """``report`` with "completed" meaning: every platform ends running only ``done``
    actors (and the run was not halted) — in one of ``came_back`` (a ``done`` actor it
    started in) only once it switched into one of them during the run; the actors still
    waiting are the others, and a ``came_back`` actor held by a platform that never left."""
    final = report["final_actors"]
    returned = {
        str(move["platform"])
        for move in report["transitions"]
        if move["to"] in came_back and move["cause"] not in ("start", "lost")
    }
    stayed = {
        a for p, actors in final.items() for a in actors if a in came_back and p not in returned
    }
    completed = (
        report.get("halted") is None
        and bool(final)
        and all(actors and set(actors) <= done for actors in final.values())
        and not stayed
    )
    waiting = {a: e for a, e in report.get("waiting", {}).items() if a not in done or a in stayed}
    return {**report, "completed": completed, "waiting": waiting}


def _completion(report: dict[str, Any]) -> float:
    """The time of the last move: every platform has since been in its final actor."""
    moves = [t["t"] for t in report["transitions"] if t["cause"] != "lost"]
    return max(moves, default=0.0)


_NUMBER = re.compile(r"\d+(\.\d+)?")
_LIST = re.compile(r"\[[^\]]*\]")
_TIME = re.compile(r"^t=[\d.]+s: ")


def signature_of(result: RunResult) -> str:
    """The failure class of a run ("" for a run that went well): the first of a crash of
    the simulator (the exception and where), a violated invariant (its sentence with the
    numbers and platform lists taken out), a separation breach, a plugin failure, or an
    incomplete task (which actors wait for which events)."""
    if result.crash is not None:
        return "simulator crash: " + _crash_site(result.crash)
    if result.violations:
        text = _TIME.sub("", result.violations[0])
        return "invariant: " + _NUMBER.sub("#", _LIST.sub("[…]", text))
    if result.breaches:
        return f"separation breach ({result.breach_actors})"
    if result.plugin_failures:
        first = result.plugin_failures[0]
        where, _, error = first.partition(": ")
        return f"plugin failure: {where.split(' on ')[0]}: {error.split(':')[0]}"
    if not result.completed:
        return "stuck: " + _NUMBER.sub("#", result.why)
    return ""


def _crash_site(tb: str) -> str:
    """``ExceptionType at file.py:LINE in function`` of the innermost frame of the project's
    own code in traceback ``tb``."""
    lines = tb.splitlines()
    exc = lines[-1].split(":")[0] if lines else "exception"
    site = ""
    for line in lines:
        m = re.match(r'\s*File ".*?(actorswarm/[^"]+)", line (\d+), in (\S+)', line)
        if m:
            site = f" at {m.group(1)}:{m.group(2)} in {m.group(3)}"
    return exc + site
