"""Moving targets: vehicles of the world that nobody commands, like the paper's jeep.

Theory of operation
-------------------
A target's motion is a pure function of time, fixed by its
:class:`~actorswarm.world.config.TargetConfig`: it waits at the first waypoint until
``start``, then drives along the route at a constant ``speed``, turning instantly at each
waypoint; a looping route closes back to the first waypoint and repeats, an open one ends at
the last waypoint and the target stays there. Nothing is integrated step by step, so a
target's position at any time costs the same and never drifts, and asking about a time twice
gives the same answer (no state, no clock).

The route is precomputed as its legs' start points, directions and cumulative lengths;
:meth:`MovingTarget.positions` looks the distance driven up with :func:`numpy.searchsorted`,
so many times are answered in one call (for pictures and tests).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np
from numpy.typing import ArrayLike, NDArray

from actorswarm.suggest import did_you_mean
from actorswarm.world.config import TargetConfig

__all__ = ["MovingTarget", "Targets"]

FloatArray = NDArray[np.float64]


class MovingTarget:
    """One target on its route (see the module docstring). ``name``, ``kind``, ``config``."""

    __slots__ = ("_cumulative", "_legs", "_starts", "_total", "_units", "config", "kind", "name")

    def __init__(self, config: TargetConfig) -> None:
        self.config = config
        self.name = config.name
        self.kind = config.kind
        points = np.asarray(config.route, dtype=np.float64).reshape(-1, 3)
        if config.loop and len(points) > 1:
            points = np.vstack((points, points[:1]))
        if len(points) == 1:
            # A single waypoint: one leg of length 0, so the lookups need no special case.
            points = np.vstack((points, points))
        legs = np.diff(points, axis=0)
        lengths = np.linalg.norm(legs, axis=1)
        self._starts = points[:-1]
        self._legs = legs
        self._units = legs / np.where(lengths > 0.0, lengths, 1.0)[:, None]
        self._cumulative = np.concatenate(([0.0], np.cumsum(lengths)))
        self._total = float(self._cumulative[-1])

    def __repr__(self) -> str:
        return f"MovingTarget({self.name!r}, kind={self.kind!r}, route length {self._total:.0f} m)"

    @property
    def route_length(self) -> float:
        """Metres driven per lap (looping) or in all (open route)."""
        return self._total

    def _driven(self, times: FloatArray) -> tuple[FloatArray, NDArray[np.bool_]]:
        """Distance along the route at each time, and whether the target moves then."""
        config = self.config
        elapsed = np.maximum(times - config.start, 0.0)
        distance = elapsed * config.speed
        moving = (times >= config.start) & (config.speed > 0.0) & (self._total > 0.0)
        if self._total <= 0.0:
            return np.zeros_like(distance), moving
        if config.loop:
            return np.mod(distance, self._total), moving
        return np.minimum(distance, self._total), moving & (distance < self._total)

    def _leg(self, driven: FloatArray) -> NDArray[np.intp]:
        leg = np.searchsorted(self._cumulative, driven, side="right") - 1
        return np.clip(leg, 0, len(self._legs) - 1)

    def positions(self, times: ArrayLike) -> FloatArray:
        """``(m, 3)`` positions at the ``m`` ``times`` (seconds)."""
        t = np.asarray(times, dtype=np.float64).reshape(-1)
        driven, _ = self._driven(t)
        leg = self._leg(driven)
        along = driven - self._cumulative[leg]
        out: FloatArray = self._starts[leg] + self._units[leg] * along[:, None]
        return out

    def velocities(self, times: ArrayLike) -> FloatArray:
        """``(m, 3)`` velocities at the ``m`` ``times`` (zero while waiting or stopped).
        At a waypoint the velocity is already the next leg's."""
        t = np.asarray(times, dtype=np.float64).reshape(-1)
        driven, moving = self._driven(t)
        out: FloatArray = self._units[self._leg(driven)] * (self.config.speed * moving)[:, None]
        return out

    def position(self, t: float) -> tuple[float, float, float]:
        """Where the target is at time ``t``."""
        p = self.positions([t])[0]
        return (float(p[0]), float(p[1]), float(p[2]))

    def velocity(self, t: float) -> tuple[float, float, float]:
        """How fast it moves at time ``t``, m/s."""
        v = self.velocities([t])[0]
        return (float(v[0]), float(v[1]), float(v[2]))


class Targets:
    """The world's targets in file order; also looked up by name (``targets["jeep"]``)."""

    def __init__(self, configs: Iterable[TargetConfig]) -> None:
        self._items = tuple(MovingTarget(c) for c in configs)
        self._by_name = {t.name: t for t in self._items}

    def __len__(self) -> int:
        return len(self._items)

    def __iter__(self) -> Iterator[MovingTarget]:
        return iter(self._items)

    def __getitem__(self, key: int | str) -> MovingTarget:
        if isinstance(key, str):
            try:
                return self._by_name[key]
            except KeyError:
                names = list(self._by_name)
                raise KeyError(
                    f"no target {key!r}{did_you_mean(key, names)}; "
                    f"targets: {', '.join(map(repr, names)) or 'none'}"
                ) from None
        return self._items[key]

    @property
    def names(self) -> tuple[str, ...]:
        """The target names, in file order."""
        return tuple(self._by_name)

    def positions(self, t: float) -> FloatArray:
        """``(k, 3)`` positions of the ``k`` targets at time ``t``."""
        if not self._items:
            return np.zeros((0, 3))
        return np.vstack([target.positions([t]) for target in self._items])

    def at(self, t: float) -> dict[str, tuple[float, float, float]]:
        """Each target's position at time ``t``, by name."""
        return {target.name: target.position(t) for target in self._items}
