"""The shipped missions: the paper's two (§V.B–C) and a reorganization, ready to run.

Each :class:`Mission` names a task script and a world file shipped in this package (the
same files as ``examples/``), the ground-station events the operator fires and when, and
how long to run. ``actorswarm demo --mission NAME`` runs one; the script's own
``<?actorswarm sim ...?>`` line is the equivalent ``actorswarm sim`` command (a test keeps
the two in agreement).

``formation``
    30 fixed-wing UAVs: arrow → two arrows → a branch into a line sub-swarm → six arrows →
    herringbone → arrow → return (the paper's Fig. 10).
``search-track``
    10 quadrotors: take-off → ingress in arrow formation → area search split among them →
    the first to see the jeep tracks it → return on ``go_home_event`` (Fig. 11).
``battery``
    The same search and track, but the tracker's battery is nearly empty: it dies and falls
    mid-track, and ``Track_lost`` promotes another searcher.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path
from typing import Final

from actorswarm.suggest import did_you_mean

__all__ = ["MISSIONS", "Mission", "mission", "mission_file"]


def mission_file(name: str) -> Path:
    """The path of a file shipped with the missions (a script or a world)."""
    path = Path(str(files(__name__).joinpath(name)))
    if not path.is_file():
        raise FileNotFoundError(f"no mission file {name!r} in {path.parent}")
    return path


@dataclass(frozen=True, slots=True, kw_only=True)
class Mission:
    """One runnable mission.

    ``events`` are ``(event name, seconds)`` the ground station fires; ``duration`` is how
    long the run lasts (virtual seconds); ``kills`` are ``(platform, seconds)`` crashes of
    the robustness variants. ``platforms`` is the number the script is written for.
    """

    name: str
    title: str
    script: str
    world: str
    events: tuple[tuple[str, float], ...]
    duration: float
    platforms: int
    kills: tuple[tuple[int, float], ...] = ()

    @property
    def script_path(self) -> Path:
        return mission_file(self.script)

    @property
    def world_path(self) -> Path:
        return mission_file(self.world)

    def sim_arguments(self) -> list[str]:
        """The ``actorswarm sim`` options that run this mission (after the script)."""
        out = ["--world", f"examples/worlds/{self.world}", "--duration", f"{self.duration:g}"]
        for event, t in self.events:
            out += ["--event", f"{event}@{t:g}"]
        for platform, t in self.kills:
            out += ["--kill", f"{platform}@{t:g}"]
        return out

    def with_kills(self, *kills: tuple[int, float]) -> Mission:
        return dataclasses.replace(self, kills=self.kills + kills)


MISSIONS: Final[dict[str, Mission]] = {
    m.name: m
    for m in (
        Mission(
            name="formation",
            title="the paper's formation mission: 30 fixed-wing UAVs, six formations",
            script="formation_30.xml",
            world="formation_30.toml",
            events=(
                ("AtoB_event", 55.0),
                ("BtoBC_branching_event", 90.0),
                ("BCtoD_event", 125.0),
                ("DtoE_event", 160.0),
                ("EtoA_event", 195.0),
                ("go_home_event", 230.0),
            ),
            duration=260.0,
            platforms=30,
        ),
        Mission(
            name="search-track",
            title="the paper's search and track: 10 quadrotors find and follow a jeep",
            script="search_track_10.xml",
            world="search_track_10.toml",
            events=(("go_home_event", 200.0),),
            duration=300.0,
            platforms=10,
        ),
        Mission(
            name="battery",
            title="reorganization: the tracker's battery dies, Track_lost promotes another",
            script="search_track_10.xml",
            world="battery_track_10.toml",
            events=(("go_home_event", 200.0),),
            duration=300.0,
            platforms=10,
        ),
    )
}


def mission(name: str) -> Mission:
    """The mission called ``name``; KeyError with a suggestion when there is none."""
    try:
        return MISSIONS[name]
    except KeyError:
        raise KeyError(
            f"no mission {name!r}{did_you_mean(name, list(MISSIONS))}; "
            f"missions: {', '.join(MISSIONS)}"
        ) from None
