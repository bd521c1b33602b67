"""Platforms whose links come and go, noticed and said once in the daemon's log.

A robot at the edge of a radio's range, or between two relays' ranges (docs/deploying.md,
"Radios"), drops out of the swarm and comes back again and again: each time the others
count it gone, and it counts its master lost. The core handles each of these as it
should (a leave, a join, an election), and each leaves its line in the log, but a row of
``master`` lines does not tell an operator which robot's radio is the trouble.
:class:`FlapWatch` counts, over a sliding window, how often each platform dropped out of
this platform's view, and how often this platform lost its master; at :data:`FLAP_TIMES`
within :data:`FLAP_WINDOW_S` it returns one ``flapping`` line naming the platform, then
stays quiet about it for a window. One failover or one partition is one drop per platform:
under the threshold.

Time is an input (the daemon's monotonic clock): the watch reads no clock of its own.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any, Final

__all__ = ["BLIND_S", "FLAP_CHECK_S", "FLAP_TIMES", "FLAP_WINDOW_S", "FlapWatch"]

#: The sliding window, seconds, over which drops are counted.
FLAP_WINDOW_S: Final = 60.0
#: Drops of one platform within the window that make it flapping.
FLAP_TIMES: Final = 3
#: How often the daemon's loop looks (it wakes for every burst of packets).
FLAP_CHECK_S: Final = 0.25
#: Seconds after this platform lost its master in which the others leaving its view are
#: not counted against them (its own links went: it sees everyone go).
BLIND_S: Final = 3.0


@dataclass(slots=True)
class FlapWatch:
    """Drops of each platform seen by ``platform`` (its own key: its master lost)."""

    platform: int
    window: float = FLAP_WINDOW_S
    times: int = FLAP_TIMES
    _members: frozenset[int] = frozenset()
    _master: int | None = None
    _drops: dict[int, deque[float]] = field(default_factory=dict)
    _said: dict[int, float] = field(default_factory=dict)
    _lost_at: float = -math.inf

    def observe(self, t: float, members: Iterable[int], master: int | None) -> list[dict[str, Any]]:
        """The platform's view (``members``, itself left out) and master at ``t``; returns
        the fields of each ``flapping`` line to write now (usually none)."""
        lines: list[dict[str, Any]] = []
        previous = self._master
        # Lost: it followed another platform and now follows nobody, or another one. A
        # platform that was its own master and follows one again has not lost anything.
        if previous is not None and previous not in (self.platform, master):
            self._drop(t, self.platform, lines)
            self._lost_at = t
        self._master = master
        now = frozenset(members)
        # A platform whose own links went sees every other one go with them: those drops
        # are its own, counted once above, not the others'.
        if t - self._lost_at > BLIND_S:
            for gone in sorted(self._members - now):
                self._drop(t, gone, lines)
        self._members = now
        return lines

    def counts(self, t: float) -> dict[int, int]:
        """Each platform's drops within the window ending at ``t`` (those with any)."""
        return {
            p: n for p, q in self._drops.items() if (n := sum(1 for d in q if d > t - self.window))
        }

    def _drop(self, t: float, platform: int, lines: list[dict[str, Any]]) -> None:
        drops = self._drops.setdefault(platform, deque())
        drops.append(t)
        while drops and drops[0] <= t - self.window:
            drops.popleft()
        if len(drops) < self.times or t - self._said.get(platform, -self.window) < self.window:
            return
        self._said[platform] = t
        n, seconds = len(drops), round(t - drops[0], 1)
        if platform == self.platform:
            what = f"this platform lost its master {n} times in {seconds:g} s"
        else:
            what = f"platform {platform} dropped out of the swarm {n} times in {seconds:g} s"
        lines.append(
            {
                "platform": platform,
                "times": n,
                "seconds": seconds,
                "why": what + ": its radio links come and go (a robot at the edge of a "
                "radio's range, or between two relays' ranges); keep its links steady, or "
                "expect it out of the swarm for a second or so each time (docs/deploying.md, "
                "Radios)",
            }
        )
