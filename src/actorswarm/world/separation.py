"""Separation: how close airborne vehicles come to one another, against a least distance.

Theory of operation
-------------------
Every vehicle kind has a least separation (the world file's ``[quadrotor] separation`` and
``[fixed_wing] separation``: 3 m and 10 m by default); a pair of vehicles must keep the
larger of its two kinds' minimums. A :class:`SeparationMonitor` is fed snapshots —
``observe(t, positions, airborne)`` — by whoever owns the positions (the simulator after
every physics step, the ground station on every reported position) and keeps, for the whole
run:

* the least distance between any two airborne vehicles, with when and where;
* the closest pairs (each pair's own least distance, the :data:`CLOSEST` closest pairs);
* every *breach*: a stretch of consecutive snapshots in which a pair is closer than its
  minimum, with its least distance, when and where that was. A pair that comes apart and
  closes in again is a second breach.

Only airborne vehicles count (a vehicle on the ground, parked at home or wrecked, is
nobody's collision risk in the air): the caller says which are.

Cost. A snapshot builds a k-d tree of the airborne positions (:class:`scipy.spatial.
cKDTree`) and asks it for every pair within the watch radius (twice the largest minimum)
and for each vehicle's nearest neighbour, so a snapshot of ``n`` vehicles costs
``O(n log n)`` rather than the ``n²/2`` distances of a full matrix; 1000 vehicles take
about a millisecond (docs/safety.md gives the measured figures).

Sampling. Distances are measured at the snapshots only: between two, vehicles closing at
``v`` m/s may pass up to ``v·Δt/2`` closer than measured. The simulator samples every
physics step (0.05 s by default: 1.25 m at a 50 m/s closing speed).

The monitor is plain data in, plain data out (no clock, no I/O): :meth:`SeparationMonitor.
result` gives a frozen :class:`SeparationReport` whose :meth:`~SeparationReport.as_dict`
goes into a run's JSON report and whose :meth:`~SeparationReport.violations` are the
report's ``violations`` lines.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "BREACH_PREFIX",
    "CLOSEST",
    "DEFAULT_SEPARATION",
    "MIN_HEIGHT",
    "VIOLATIONS_LISTED",
    "Breach",
    "Encounter",
    "SeparationBreachError",
    "SeparationMonitor",
    "SeparationReport",
    "separation_line",
]

FloatArray = NDArray[np.float64]

#: The least separation of each vehicle kind when the world file says nothing, metres: what
#: a pilot would accept between two small fixed-wings (~2 m span at 15–25 m/s) and two
#: small multirotors.
DEFAULT_SEPARATION: Final[Mapping[str, float]] = {"fixed_wing": 10.0, "quadrotor": 3.0}
#: How many of the closest pairs a report keeps.
CLOSEST: Final = 5
#: A report's ``violations`` list at most this many breaches one by one, then a count.
VIOLATIONS_LISTED: Final = 20
#: How every separation line of a report's ``violations`` begins.
BREACH_PREFIX: Final = "separation breach:"
#: A vehicle lower than this (metres above the ground) is on the ground, whatever its mode.
MIN_HEIGHT: Final = 1.0


@dataclass(frozen=True, slots=True)
class Encounter:
    """Two vehicles' least distance: ``distance`` metres at ``t`` seconds, the midpoint
    between them at ``where`` (x, y, z); ``minimum`` is what the pair must keep."""

    a: int
    b: int
    distance: float
    t: float
    where: tuple[float, float, float]
    minimum: float

    def as_dict(self) -> dict[str, Any]:
        return {
            "platforms": [self.a, self.b],
            "distance_m": round(self.distance, 3),
            "t": round(self.t, 3),
            "where": [round(v, 1) for v in self.where],
            "minimum_m": self.minimum,
        }

    def describe(self) -> str:
        x, y, z = self.where
        return (
            f"platforms {self.a} and {self.b} {self.distance:.2f} m apart at "
            f"t = {self.t:.1f} s near ({x:.0f}, {y:.0f}, {z:.0f})"
        )


@dataclass(frozen=True, slots=True)
class Breach:
    """A pair closer than its minimum from ``start`` to ``end`` seconds (the last snapshot
    still in breach); ``closest`` is the least distance during it."""

    start: float
    end: float
    closest: Encounter

    def as_dict(self) -> dict[str, Any]:
        return {**self.closest.as_dict(), "start": round(self.start, 3), "end": round(self.end, 3)}

    def describe(self) -> str:
        c = self.closest
        return (
            f"{BREACH_PREFIX} {c.describe()}, under the {c.minimum:g} m minimum from "
            f"{self.start:.1f} s to {self.end:.1f} s"
        )


class SeparationBreachError(RuntimeError):
    """A breach in a run where a breach is fatal: the run stops at it."""

    def __init__(self, breach: Breach) -> None:
        super().__init__(breach.describe())
        self.breach = breach


@dataclass(frozen=True, slots=True)
class SeparationReport:
    """What a :class:`SeparationMonitor` saw (module docstring)."""

    minimums: Mapping[str, float]
    samples: int
    airborne_samples: int
    breach_samples: int
    closest: Encounter | None
    pairs: tuple[Encounter, ...]
    breaches: tuple[Breach, ...]
    fatal: bool = False
    halted: Breach | None = None

    @property
    def held(self) -> bool:
        """Whether every pair kept its minimum at every snapshot."""
        return not self.breaches

    def as_dict(self) -> dict[str, Any]:
        """The JSON-ready form (a run report's ``separation``)."""
        return {
            "minimums_m": dict(self.minimums),
            "fatal": self.fatal,
            "samples": self.samples,
            "airborne_samples": self.airborne_samples,
            "breach_samples": self.breach_samples,
            "min_distance_m": None if self.closest is None else round(self.closest.distance, 3),
            "closest": None if self.closest is None else self.closest.as_dict(),
            "closest_pairs": [e.as_dict() for e in self.pairs],
            "breaches": [b.as_dict() for b in self.breaches],
            "halted": None if self.halted is None else self.halted.as_dict(),
        }

    def violations(self) -> list[str]:
        """One line per breach (the first :data:`VIOLATIONS_LISTED`, then a count): what a
        run's ``violations`` gets."""
        lines = [b.describe() for b in self.breaches[:VIOLATIONS_LISTED]]
        more = len(self.breaches) - VIOLATIONS_LISTED
        if more > 0:
            lines.append(f"{BREACH_PREFIX} ... and {more} more (all in the report's separation)")
        return lines


@dataclass(slots=True)
class SeparationMonitor:
    """The separation of ``platforms`` (IDs, one per row of every snapshot), where row
    ``i`` must keep ``minimum[i]`` metres from everyone (a pair: the larger of its two).
    ``fatal``: :meth:`observe` raises :class:`SeparationBreachError` on the first breach.
    ``minimums``: the per-kind figures, for the report only."""

    platforms: Sequence[int]
    minimum: Sequence[float]
    fatal: bool = False
    minimums: Mapping[str, float] = field(default_factory=dict)
    _ids: NDArray[np.int64] = field(init=False)
    _min: FloatArray = field(init=False)
    _watch: float = field(init=False)
    samples: int = field(default=0, init=False)
    _airborne_samples: int = field(default=0, init=False)
    _breach_samples: int = field(default=0, init=False)
    _closest: Encounter | None = field(default=None, init=False)
    _pairs: dict[tuple[int, int], Encounter] = field(default_factory=dict, init=False)
    _open: dict[tuple[int, int], tuple[float, float, Encounter]] = field(
        default_factory=dict, init=False
    )
    _done: list[Breach] = field(default_factory=list, init=False)
    _halted: Breach | None = field(default=None, init=False)

    def __post_init__(self) -> None:
        if len(self.platforms) != len(self.minimum):
            raise ValueError(
                f"{len(self.platforms)} platforms but {len(self.minimum)} minimum separations"
            )
        if any(not (math.isfinite(m) and m > 0) for m in self.minimum):
            raise ValueError("every minimum separation must be a number of metres > 0")
        self._ids = np.asarray(self.platforms, dtype=np.int64)
        self._min = np.asarray(self.minimum, dtype=np.float64)
        # Pairs within twice the largest minimum are followed for the closest-pairs table.
        self._watch = 2.0 * float(self._min.max()) if len(self._min) else 0.0

    def add(self, platform: int, minimum: float) -> int:
        """A platform that joined (a real swarm's, seen by its ground station): a new last
        row, returned. ValueError for a platform already there or a bad minimum."""
        if platform in self._ids.tolist():
            raise ValueError(f"platform {platform} is already watched")
        if not (math.isfinite(minimum) and minimum > 0):
            raise ValueError("a minimum separation must be a number of metres > 0")
        self._ids = np.append(self._ids, np.int64(platform))
        self._min = np.append(self._min, float(minimum))
        self._watch = 2.0 * float(self._min.max())
        return len(self._ids) - 1

    def observe(self, t: float, positions: FloatArray, airborne: NDArray[np.bool_]) -> list[Breach]:
        """Take the snapshot at ``t`` seconds: ``positions`` ``(n, 3)`` in row order and
        which rows are ``airborne`` (a row lower than :data:`MIN_HEIGHT` never is). Return
        the breaches that began at this snapshot (their ``end`` is ``t`` so far)."""
        from scipy.spatial import cKDTree

        self.samples += 1
        rows = np.flatnonzero(airborne & (positions[:, 2] >= MIN_HEIGHT))
        if len(rows) < 2:
            self._close_all(set())
            return []
        self._airborne_samples += 1
        pts = positions[rows]
        tree = cKDTree(pts)
        nearest, which = tree.query(pts, k=2)
        k = int(np.argmin(nearest[:, 1]))
        i, j = int(rows[k]), int(rows[int(which[k, 1])])
        # The distance as _encounter measures it; the encounter is built only for a new
        # closest (rarely, after the first seconds of a run).
        d = float(np.linalg.norm(positions[i] - positions[j]))
        if self._closest is None or d < self._closest.distance:
            self._closest = self._encounter(i, j, positions, t, d)
        pairs = tree.query_pairs(self._watch, output_type="ndarray")
        started: list[Breach] = []
        in_breach: set[tuple[int, int]] = set()
        if len(pairs):
            ri, rj = rows[pairs[:, 0]], rows[pairs[:, 1]]
            dist = np.linalg.norm(positions[ri] - positions[rj], axis=1)
            need = np.maximum(self._min[ri], self._min[rj])
            # A pair whose least distance is among the CLOSEST least of the run is among
            # the CLOSEST nearest at the snapshot of that least: only those are followed.
            near = np.argpartition(dist, CLOSEST)[:CLOSEST] if len(dist) > CLOSEST else None
            for k in range(len(dist)) if near is None else near.tolist():
                self._follow(int(ri[k]), int(rj[k]), float(dist[k]), float(need[k]), positions, t)
            for k in np.flatnonzero(dist < need).tolist():
                a, b, d, m = int(ri[k]), int(rj[k]), float(dist[k]), float(need[k])
                key = (min(a, b), max(a, b))
                in_breach.add(key)
                opened = self._open.get(key)
                if opened is None:
                    enc = self._encounter(key[0], key[1], positions, t, d, m)
                    self._open[key] = (t, t, enc)
                    started.append(Breach(t, t, enc))
                else:
                    first, _, enc = opened
                    if d < enc.distance:
                        enc = self._encounter(key[0], key[1], positions, t, d, m)
                    self._open[key] = (first, t, enc)
        if in_breach:
            self._breach_samples += 1
        self._close_all(in_breach)
        if started and self.fatal and self._halted is None:
            self._halted = started[0]
            raise SeparationBreachError(started[0])
        return started

    def _follow(self, a: int, b: int, d: float, m: float, positions: FloatArray, t: float) -> None:
        key = (min(a, b), max(a, b))
        best = self._pairs.get(key)
        if best is None or d < best.distance:
            self._pairs[key] = self._encounter(key[0], key[1], positions, t, d, m)
        if len(self._pairs) > 4 * CLOSEST:
            keep = sorted(self._pairs.items(), key=lambda kv: kv[1].distance)[:CLOSEST]
            self._pairs = dict(keep)

    def _encounter(
        self,
        i: int,
        j: int,
        positions: FloatArray,
        t: float,
        distance: float | None = None,
        minimum: float | None = None,
    ) -> Encounter:
        p, q = positions[i], positions[j]
        mid = (p + q) / 2.0
        a, b = int(self._ids[i]), int(self._ids[j])
        return Encounter(
            a=min(a, b),
            b=max(a, b),
            distance=float(np.linalg.norm(p - q)) if distance is None else distance,
            t=float(t),
            where=(float(mid[0]), float(mid[1]), float(mid[2])),
            minimum=float(max(self._min[i], self._min[j])) if minimum is None else minimum,
        )

    def _close_all(self, keep: set[tuple[int, int]]) -> None:
        for key in [k for k in self._open if k not in keep]:
            first, last, enc = self._open.pop(key)
            self._done.append(Breach(first, last, enc))

    def result(self) -> SeparationReport:
        """Everything seen so far (breaches still open count, up to the last snapshot)."""
        breaches = [*self._done, *(Breach(f, last, e) for f, last, e in self._open.values())]
        breaches.sort(key=lambda b: (b.start, b.closest.a, b.closest.b))
        pairs = sorted(self._pairs.values(), key=lambda e: (e.distance, e.a, e.b))[:CLOSEST]
        return SeparationReport(
            minimums=dict(self.minimums),
            samples=self.samples,
            airborne_samples=self._airborne_samples,
            breach_samples=self._breach_samples,
            closest=self._closest,
            pairs=tuple(pairs),
            breaches=tuple(breaches),
            fatal=self.fatal,
            halted=self._halted,
        )


def separation_line(separation: dict[str, Any]) -> str:
    """A run report's ``separation`` in one line for people: the least distance between two
    airborne vehicles, and how many breaches."""
    mins = ", ".join(f"{k} {v:g} m" for k, v in separation["minimums_m"].items())
    closest = separation["closest"]
    if closest is None:
        return f"separation: no two vehicles airborne together (minimums: {mins})"
    a, b = closest["platforms"]
    x, y, z = closest["where"]
    head = (
        f"separation: closest {closest['distance_m']:.2f} m (platforms {a} and {b} at "
        f"{closest['t']:.1f} s near ({x:.0f}, {y:.0f}, {z:.0f})); minimums: {mins}"
    )
    breaches = separation["breaches"]
    if not breaches:
        return f"{head}; held at every instant"
    return (
        f"{head}; {len(breaches)} BREACH(ES) at {separation['breach_samples']} of "
        f"{separation['samples']} instants"
    )
