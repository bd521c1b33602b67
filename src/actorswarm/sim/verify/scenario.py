"""The scenario a script carries on its ``<?actorswarm sim ...?>`` line: the world, the
duration, the operator's events and any fault the mission itself includes.

``task verify`` starts from it when its own options leave a part out, so that verifying a
shipped mission takes nothing but its file. Paths on the line are relative to where the
line's script path is: for ``<?actorswarm sim examples/formation_30.xml --world
examples/worlds/formation_30.toml ...?>`` in ``/x/examples/formation_30.xml``, the world is
``/x/examples/worlds/formation_30.toml``, from any working directory.
"""

from __future__ import annotations

import re
import shlex
from dataclasses import dataclass
from pathlib import Path

from actorswarm.sim.tasksim import Fault, GroundEvent, parse_event, parse_fault

__all__ = ["Scenario", "scenario_of"]

_LINE = re.compile(r"<\?actorswarm\s+sim\s+(.*?)\?>", re.DOTALL)
_FAULTS = ("kill", "restart", "partition", "heal")


@dataclass(frozen=True, slots=True)
class Scenario:
    world: Path | None = None
    no_world: bool = False
    duration: float | None = None
    events: tuple[GroundEvent, ...] = ()
    faults: tuple[Fault, ...] = ()
    #: The options of the line that verify does not take (said to the user).
    ignored: tuple[str, ...] = ()


def scenario_of(text: str, script: Path) -> Scenario | None:
    """The scenario of the first ``<?actorswarm sim ...?>`` line of the script ``text``
    (at ``script``); None without one. ValueError naming the option for a line that cannot
    be read."""
    found = _LINE.search(text)
    if found is None:
        return None
    try:
        words = shlex.split(found.group(1))
    except ValueError as exc:
        raise ValueError(f"its <?actorswarm sim ...?> line cannot be read: {exc}") from None
    base = _base(script, words[0] if words else "")
    world: Path | None = None
    no_world = False
    duration: float | None = None
    events: list[GroundEvent] = []
    faults: list[Fault] = []
    ignored: list[str] = []
    i = 1
    while i < len(words):
        word = words[i]
        name, eq, inline = word.partition("=")
        takes_value = name not in ("--no-world", "--expect-complete")
        value = inline if eq else (words[i + 1] if takes_value and i + 1 < len(words) else "")
        i += 1 if eq or not takes_value else 2
        try:
            if name == "--world":
                world = (base / value) if not Path(value).is_absolute() else Path(value)
            elif name == "--no-world":
                no_world = True
            elif name == "--duration":
                duration = float(value)
            elif name == "--event":
                events.append(parse_event(value))
            elif name.removeprefix("--") in _FAULTS:
                faults.append(parse_fault(name.removeprefix("--"), value))
            else:
                ignored.append(name)
        except ValueError as exc:
            raise ValueError(f"its <?actorswarm sim ...?> line: {exc}") from None
    return Scenario(world, no_world, duration, tuple(events), tuple(faults), tuple(ignored))


def _base(script: Path, written: str) -> Path:
    """The directory the line's paths are relative to: the script's own directory, less
    the directories the line's script path names."""
    # Not resolve(): a script linked into another directory keeps its own neighbours.
    here = script.absolute().parent
    parts = Path(written).parent.parts if written else ()
    if parts and here.parts[-len(parts) :] == parts:
        return Path(*here.parts[: -len(parts)]) if len(here.parts) > len(parts) else Path("/")
    return here
