"""How many radio hops a simulated swarm spans, watched over a run.

:class:`HopWatch` asks the world (:meth:`~actorswarm.world.world.World.hop_span`) at the
start and then at most once per ``interval`` seconds of world time, and keeps what a
report says of it: the span at the start, the largest seen, and for how long the swarm was
split into groups that could not reach each other even hop by hop. Without the radio's
``relay`` a span above one hop means some platforms do not hear each other at all: nothing
in the swarm forwards a packet for another. With it, packets cross those hops through
relays.

The span costs a few boolean matrix products over the platforms (:func:`~actorswarm.world.
radio_model.hops`): negligible at 30 platforms, about 10 ms at 300, so above
:data:`WATCH_LIMIT` platforms only the start is measured.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

__all__ = ["WATCH_LIMIT", "HopWatch", "hops_line"]

#: Above this many platforms, the span is measured at the start only.
WATCH_LIMIT = 200


class _World(Protocol):
    @property
    def time(self) -> float: ...
    @property
    def platforms(self) -> tuple[int, ...]: ...
    def hop_span(self) -> tuple[int, int]: ...


@dataclass(slots=True)
class HopWatch:
    """The swarm's radio span over a run (module docstring); ``relay``: the world's."""

    relay: bool
    interval: float = 1.0
    at_start: int | None = None
    most: int = 0
    groups: int = 1
    split_s: float = 0.0
    samples: int = 0
    _next: float = 0.0
    _last: float | None = None
    _split: bool = False

    def observe(self, world: _World) -> None:
        """Sample ``world`` if ``interval`` has passed since the last sample."""
        t = world.time
        if t < self._next or (self.samples and len(world.platforms) > WATCH_LIMIT):
            return
        span, groups = world.hop_span()
        if self._last is not None and self._split:
            self.split_s += t - self._last
        self._last, self._split = t, groups > 1
        if self.at_start is None:
            self.at_start = span
        self.most = max(self.most, span)
        self.groups = max(self.groups, groups)
        self.samples += 1
        self._next = t + self.interval

    def as_dict(self) -> dict[str, Any]:
        return {
            "relay": self.relay,
            "hops_at_start": self.at_start,
            "most_hops": self.most,
            "most_groups": self.groups,
            "split_s": round(self.split_s, 3),
            "samples": self.samples,
        }


def hops_line(radio: dict[str, Any]) -> str:
    """The report's ``radio`` entry in one line."""
    most = radio["most_hops"]
    start = radio["hops_at_start"]
    span = f"{start} hop{'s' if start != 1 else ''} at the start, at most {most}"
    how = "relayed ([radio] relay)" if radio["relay"] else "no relay"
    line = f"radio: the swarm spans {span}; {how}"
    if radio["most_groups"] > 1:
        line += (
            f"; SPLIT into up to {radio['most_groups']} groups out of each other's reach for "
            f"{radio['split_s']:.1f} s"
        )
    if most > 1 and not radio["relay"]:
        line += "; platforms more than one hop apart never hear each other"
    return line
