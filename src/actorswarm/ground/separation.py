"""A real swarm's separation, from the positions its platforms report to the ground station.

The simulator knows every position at every physics step; a ground station knows what the
platforms' status replies carry, as often as it asks (``gs record --poll``). A
:class:`SwarmSeparation` keeps each platform's latest reported position and, at each look,
measures the pairs whose positions are both fresh (no older than ``max_age`` seconds) and
airborne, with the simulator's :class:`~actorswarm.world.separation.SeparationMonitor`:
the same report, closest pairs and breaches. It is as good as the positions: a GPS fix
of a few metres and a poll of half a second make the figures coarser than a simulation's,
and a stale position is left out rather than compared with a fresh one.

The station does not know the vehicles' kinds, so every pair must keep ``minimum`` metres
(``gs record --min-separation``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from actorswarm.world.separation import Breach, SeparationMonitor, SeparationReport

__all__ = ["SwarmSeparation"]


@dataclass(slots=True)
class SwarmSeparation:
    """The separation of the platforms whose positions :meth:`position` is told
    (module docstring)."""

    minimum: float = 3.0
    max_age: float = 2.0
    _monitor: SeparationMonitor = field(init=False)
    _rows: dict[int, int] = field(default_factory=dict, init=False)
    _seen: dict[int, tuple[float, tuple[float, float, float]]] = field(
        default_factory=dict, init=False
    )

    def __post_init__(self) -> None:
        if not (math.isfinite(self.minimum) and self.minimum > 0):
            raise ValueError(f"--min-separation must be metres > 0, not {self.minimum:g}")
        self._monitor = SeparationMonitor([], [], minimums={"every pair": self.minimum})

    def position(self, now: float, platform: int, position: Sequence[float]) -> None:
        """``platform`` reported ``position`` (x, y, z metres in the mission frame; z
        left out: on the ground) at ``now`` on the station's clock."""
        if len(position) < 2 or not all(math.isfinite(float(v)) for v in position):
            return
        z = float(position[2]) if len(position) > 2 else 0.0
        if platform not in self._rows:
            self._rows[platform] = self._monitor.add(platform, self.minimum)
        self._seen[platform] = (now, (float(position[0]), float(position[1]), z))

    def observe(self, now: float) -> list[Breach]:
        """Measure the fresh positions at ``now``: the breaches that began."""
        n = len(self._rows)
        positions = np.zeros((n, 3))
        fresh = np.zeros(n, dtype=bool)
        for platform, row in self._rows.items():
            t, xyz = self._seen[platform]
            positions[row] = xyz
            fresh[row] = now - t <= self.max_age
        return self._monitor.observe(now, positions, fresh)

    def result(self) -> SeparationReport:
        """Everything measured so far."""
        return self._monitor.result()
