"""Leave decisions: when has a peer's silence lasted long enough to call it gone?

The paper asks for "an interface for incorporating various heartbeat processing algorithms";
this is it. A detector watches one peer. Each heartbeat is fed to :meth:`observe`, which
returns the *deadline*: the time at which the peer is to be declared left if no further
heartbeat arrives. Returning a deadline instead of answering "is it dead now?" keeps the
membership table O(log N) per heartbeat (a heap of deadlines) instead of O(N) per tick, which
matters at 1000 simulated platforms.

Two detectors ship:

* :class:`FixedTimeout` — left after ``t_leave`` without a heartbeat (docs/design.md §3.1).
* :class:`PhiAccrual` — Hayashibara et al.'s accrual detector with a normal model of the
  inter-arrival times: suspicion ``phi(t) = -log10(1 - F(t - last))``; the peer is left when
  phi passes ``threshold``. Since phi grows monotonically with the silence, the crossing time is
  ``last + mean + z * std`` with ``z`` the normal quantile of ``1 - 10**-threshold``, computed
  once.
"""

from __future__ import annotations

import functools
import math
from collections import deque
from typing import Protocol

from actorswarm.core.config import CoreConfig


@functools.cache
def _quantile(threshold: float) -> float:
    """The standard normal quantile of ``1 - 10**-threshold`` (8 beyond threshold 15),
    worked out once per threshold, not per peer's detector."""
    if threshold >= 15:
        return 8.0
    # `statistics` (with `fractions` and `decimal`) is imported here rather than by every
    # daemon, which runs the timeout detector by default.
    from statistics import NormalDist

    return NormalDist().inv_cdf(1.0 - 10.0 ** (-threshold))


class LeaveDetector(Protocol):
    """Watches one peer's heartbeats."""

    def observe(self, now: float) -> float:
        """Record a heartbeat at ``now``; return when the peer leaves if none follows."""
        ...

    def suspicion(self, now: float) -> float:
        """A number that grows with the silence (seconds silent, or phi), for status views."""
        ...


class FixedTimeout:
    """Left after ``t_leave`` seconds without a heartbeat."""

    __slots__ = ("_last", "_t_leave")

    def __init__(self, t_leave: float) -> None:
        self._t_leave = t_leave
        self._last = -math.inf

    def observe(self, now: float) -> float:
        self._last = now
        return now + self._t_leave

    def suspicion(self, now: float) -> float:
        return max(0.0, now - self._last)


class PhiAccrual:
    """Phi accrual failure detector over a sliding window of inter-arrival times.

    Until two intervals are known the expected interval is ``expected_interval`` with a
    standard deviation of a quarter of it, so a fresh peer is judged like a regular one.
    ``min_std`` keeps a perfectly regular peer from being declared dead by a few ms of jitter.
    """

    __slots__ = ("_intervals", "_last", "_min_std", "_sum", "_sumsq", "_threshold", "_z")

    def __init__(
        self,
        *,
        threshold: float,
        window: int,
        min_std: float,
        expected_interval: float,
    ) -> None:
        self._threshold = threshold
        self._min_std = min_std
        self._z = _quantile(threshold)
        self._intervals: deque[float] = deque(maxlen=window)
        self._sum = 0.0
        self._sumsq = 0.0
        self._last = -math.inf
        # Seed the window with the nominal interval so early deadlines are sensible.
        self._push(expected_interval)
        self._push(expected_interval * 1.25)
        self._push(expected_interval * 0.75)

    def _push(self, interval: float) -> None:
        if len(self._intervals) == self._intervals.maxlen:
            old = self._intervals[0]
            self._sum -= old
            self._sumsq -= old * old
        self._intervals.append(interval)
        self._sum += interval
        self._sumsq += interval * interval

    def _stats(self) -> tuple[float, float]:
        n = len(self._intervals)
        mean = self._sum / n
        var = max(0.0, self._sumsq / n - mean * mean)
        return mean, max(math.sqrt(var), self._min_std)

    def observe(self, now: float) -> float:
        if math.isfinite(self._last) and now > self._last:
            self._push(now - self._last)
        self._last = now
        mean, std = self._stats()
        return now + mean + self._z * std

    def phi(self, now: float) -> float:
        """Current suspicion level; ``threshold`` is where the peer is declared left."""
        if not math.isfinite(self._last):
            return 0.0
        mean, std = self._stats()
        # The normal distribution's survival function, P(interval > silence).
        p_later = 0.5 * math.erfc((now - self._last - mean) / (std * math.sqrt(2.0)))
        if p_later <= 0.0:
            return math.inf
        return -math.log10(p_later)

    def suspicion(self, now: float) -> float:
        return self.phi(now)


def make_detector(config: CoreConfig) -> LeaveDetector:
    """The detector ``config.detector`` names, for one peer."""
    if config.detector == "phi":
        return PhiAccrual(
            threshold=config.phi_threshold,
            window=config.phi_window,
            min_std=config.phi_min_std,
            expected_interval=config.heartbeat_interval,
        )
    return FixedTimeout(config.t_leave)
