"""Fault profiles: what can go wrong in a ``task verify`` run, and how often.

A profile is a TOML file of up to five tables; every key is optional and falls back to the
default profile (:data:`DEFAULT_PROFILE`, the values below). A *range* ``[a, b]`` is drawn
uniformly in each run; a *rate* is the mean of a Poisson-distributed count per run; a
*chance* is a probability per run (or per platform, where it says so)::

    [radio]                  # the whole run's radio, on top of the world's distance model
    loss = [0.0, 0.15]       # packet loss probability of every link
    latency_ms = [5, 40]     # one-way latency
    jitter_ms = [0, 20]      # extra random latency

    [kills]                  # platforms that crash
    platforms = "1-10"       # only these (default: any); IDs as in a script, "1-4,7"
    rate = 1.0               # crashes per run
    master = 0.4             # chance a crash is of whoever is master then
    after_event = 0.5        # chance it falls just after an operator event (mid-barrier)
    after_event_s = [0, 1.5] #   ... this long after it; otherwise anywhere in the run
    restart = 0.5            # chance the platform reboots
    restart_after_s = [3, 30]

    [partitions]             # the radio cut in two
    rate = 0.3
    size = [0.1, 0.5]        # share of the platforms on the small side
    heal = 0.9               # chance it heals
    heal_after_s = [3, 30]

    [vehicles]               # autopilots (worlds with vehicles only); chances per platform
    late = 0.05              # ready to take off only late
    late_s = [10, 60]        #   ... at this time
    refuse = 0.02            # never arms (vehicle_fault_event after 120 s)
    drain = 0.05             # battery drains faster
    drain_factor = [1.5, 4]

    [events]                 # the operator's events
    shift = 0.5              # chance an event comes early or late
    shift_s = [-5, 5]        #   ... by this much

Faults are drawn in the span ``[0, window · duration]`` (``[run] window``, default 0.9:
a fault in the last instants could not show its effect). Every number is checked;
:func:`load_profile` names the file, the line and the key of a mistake.
"""

from __future__ import annotations

import dataclasses
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final

from actorswarm.suggest import did_you_mean

__all__ = [
    "DEFAULT_PROFILE",
    "EventFaults",
    "FaultProfile",
    "KillFaults",
    "PartitionFaults",
    "ProfileError",
    "RadioFaults",
    "RunWindow",
    "VehicleFaults",
    "load_profile",
    "profile_from_dict",
]

Range = tuple[float, float]


class ProfileError(ValueError):
    """A profile that cannot be used: ``FILE:LINE: [table] key: problem``."""


@dataclass(frozen=True, slots=True)
class RadioFaults:
    loss: Range = (0.0, 0.15)
    latency_ms: Range = (5.0, 40.0)
    jitter_ms: Range = (0.0, 20.0)


@dataclass(frozen=True, slots=True)
class KillFaults:
    #: The platforms that may crash (empty: any; "master" kills are of whoever is master).
    platforms: tuple[int, ...] = ()
    rate: float = 1.0
    master: float = 0.4
    after_event: float = 0.5
    after_event_s: Range = (0.0, 1.5)
    restart: float = 0.5
    restart_after_s: Range = (3.0, 30.0)


@dataclass(frozen=True, slots=True)
class PartitionFaults:
    rate: float = 0.3
    size: Range = (0.1, 0.5)
    heal: float = 0.9
    heal_after_s: Range = (3.0, 30.0)


@dataclass(frozen=True, slots=True)
class VehicleFaults:
    late: float = 0.05
    late_s: Range = (10.0, 60.0)
    refuse: float = 0.02
    drain: float = 0.05
    drain_factor: Range = (1.5, 4.0)


@dataclass(frozen=True, slots=True)
class EventFaults:
    shift: float = 0.5
    shift_s: Range = (-5.0, 5.0)


@dataclass(frozen=True, slots=True)
class RunWindow:
    window: float = 0.9


@dataclass(frozen=True, slots=True)
class FaultProfile:
    """Every distribution a run's fault schedule is drawn from (module docstring)."""

    radio: RadioFaults = field(default_factory=RadioFaults)
    kills: KillFaults = field(default_factory=KillFaults)
    partitions: PartitionFaults = field(default_factory=PartitionFaults)
    vehicles: VehicleFaults = field(default_factory=VehicleFaults)
    events: EventFaults = field(default_factory=EventFaults)
    run: RunWindow = field(default_factory=RunWindow)
    #: Where it came from ("the default profile" or a path), for reports.
    source: str = "the default profile"
    #: The line of each key given (``"kills.platforms"``), for the errors found later.
    lines: tuple[tuple[str, int], ...] = ()

    def problems(self, platforms: frozenset[int]) -> list[str]:
        """What cannot be in a swarm of ``platforms``: a kill of a platform it lacks."""
        from actorswarm.dsl.syntax import id_ranges

        missing = frozenset(self.kills.platforms) - platforms
        if not missing:
            return []
        line = dict(self.lines).get("kills.platforms")
        where = f"{self.source}:{line}" if line else self.source
        return [
            f"{where}: [kills] platforms: the script starts no platform "
            f"{id_ranges(missing)} (its platforms: {id_ranges(platforms)})"
        ]

    def as_dict(self) -> dict[str, Any]:
        out = dataclasses.asdict(self)
        out.pop("source")
        out.pop("lines")
        return {t: {k: list(v) if isinstance(v, tuple) else v for k, v in d.items()}
                for t, d in out.items()}  # fmt: skip


DEFAULT_PROFILE: Final = FaultProfile()

#: Each table's dataclass.
_TABLES: Final[dict[str, type[Any]]] = {
    "radio": RadioFaults,
    "kills": KillFaults,
    "partitions": PartitionFaults,
    "vehicles": VehicleFaults,
    "events": EventFaults,
    "run": RunWindow,
}

#: Keys whose value is a probability (0..1); the other single numbers are rates (>= 0).
_CHANCES: Final = {"master", "after_event", "restart", "heal", "late", "refuse", "drain",
                   "shift", "size", "loss", "window"}  # fmt: skip
#: Bounds beyond the chance/rate rule: (low, high) of every value of the key.
_BOUNDS: Final[dict[str, Range]] = {
    "loss": (0.0, 0.9),  # as `sim --loss`: beyond it no swarm forms at all
    "latency_ms": (0.0, 10_000.0),
    "jitter_ms": (0.0, 10_000.0),
    "rate": (0.0, 100.0),
    "after_event_s": (0.0, 1e6),
    "restart_after_s": (0.0, 1e6),
    "heal_after_s": (0.0, 1e6),
    "late_s": (0.0, 1e6),
    "drain_factor": (1.0, 1000.0),
    "shift_s": (-1e6, 1e6),
    "size": (0.0, 0.5),
    "window": (0.05, 1.0),
}


def load_profile(path: Path) -> FaultProfile:
    """The profile in the TOML file at ``path`` (its missing keys from the default profile).

    Raises :class:`ProfileError` naming the file, the line and the key for an unknown table
    or key (with a suggestion), a value of the wrong type, a probability outside 0..1, a
    range whose ends are swapped or out of bounds; OSError when the file cannot be read.
    """
    text = path.read_text(encoding="utf-8")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ProfileError(f"{path}: not valid TOML: {exc}") from None
    return profile_from_dict(data, source=str(path), text=text)


def profile_from_dict(
    data: dict[str, Any], *, source: str = "the profile", text: str = ""
) -> FaultProfile:
    """The profile of parsed TOML ``data`` (``text``, when given, locates mistakes)."""

    def fail(table: str, key: str | None, problem: str) -> ProfileError:
        line = _line_of(text, table, key)
        where = f"{source}:{line}" if line else source
        name = f"[{table}] {key}" if key else f"[{table}]"
        return ProfileError(f"{where}: {name}: {problem}")

    tables: dict[str, Any] = {}
    lines: list[tuple[str, int]] = []
    for name, value in data.items():
        if name not in _TABLES:
            raise ProfileError(
                f"{source}:{_line_of(text, name, None) or 1}: unknown table [{name}]"
                f"{did_you_mean(name, list(_TABLES))}; the tables are "
                f"{', '.join('[' + t + ']' for t in _TABLES)}"
            )
        if not isinstance(value, dict):
            raise fail(name, None, "must be a table")
        cls = _TABLES[name]
        defaults = cls()
        known = [f.name for f in dataclasses.fields(cls)]
        kwargs: dict[str, Any] = {}
        for key, raw in value.items():
            if key not in known:
                raise fail(
                    name, key, f"unknown key{did_you_mean(key, known)}; the keys of "
                    f"[{name}] are {', '.join(known)}"
                )  # fmt: skip
            try:
                if key == "platforms":
                    kwargs[key] = _platforms(raw)
                else:
                    kwargs[key] = _value(raw, getattr(defaults, key), key)
            except ValueError as exc:
                raise fail(name, key, str(exc)) from None
            lines.append((f"{name}.{key}", _line_of(text, name, key) or 0))
        tables[name] = cls(**kwargs)
    return FaultProfile(**tables, source=source, lines=tuple(lines))


def _platforms(raw: object) -> tuple[int, ...]:
    """Platform IDs from a string ("1-4,7") or a list of integers."""
    from actorswarm.world.config import parse_platforms

    return tuple(sorted(set(parse_platforms(raw))))


def _value(raw: object, default: object, key: str) -> object:
    """``raw`` checked as ``key``'s value (shaped as its ``default``); ValueError saying why
    not."""
    low, high = _BOUNDS.get(key, (0.0, 1.0 if key in _CHANCES else 1e6))
    if isinstance(default, tuple):
        if not (isinstance(raw, list) and len(raw) == 2 and all(_number(v) for v in raw)):
            raise ValueError(f"must be a range [low, high] of two numbers, not {raw!r}")
        a, b = float(raw[0]), float(raw[1])
        if a > b:
            raise ValueError(f"the range's low end {a:g} is above its high end {b:g}")
        if a < low or b > high:
            raise ValueError(f"must lie within [{low:g}, {high:g}], not [{a:g}, {b:g}]")
        return (a, b)
    if not _number(raw):
        raise ValueError(f"must be a number, not {raw!r}")
    value = float(raw)  # type: ignore[arg-type]
    if not low <= value <= high:
        what = "a probability" if key in _CHANCES else "a number"
        raise ValueError(f"must be {what} within {low:g}..{high:g}, not {value:g}")
    return value


def _number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _line_of(text: str, table: str, key: str | None) -> int | None:
    """The 1-based line of ``[table]`` (``key`` None) or of ``key = ...`` inside it."""
    current = ""
    for number, line in enumerate(text.splitlines(), start=1):
        header = re.match(r"\s*\[\s*([A-Za-z0-9_.-]+)\s*\]", line)
        if header:
            current = header.group(1)
            if key is None and current == table:
                return number
            continue
        if key is not None and current == table and re.match(rf"\s*{re.escape(key)}\s*=", line):
            return number
    return None
