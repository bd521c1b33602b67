"""Round-trip-time estimation for retransmission delays (the RFC 6298 estimator).

The paper retransmits with a delay that grows linearly; the first delay of that line is best
set from the radio as it is. Each acknowledged message that was sent exactly once (Karn's
rule: a retransmitted one cannot tell which copy was acknowledged) gives a sample; the
estimator keeps a smoothed RTT and its variation, and the retransmission timeout is
``srtt + max(4 * rttvar, floor)``, clamped to ``[floor, cap]``. Before any sample it is the
configured initial delay.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(slots=True)
class RttEstimator:
    """Smoothed round-trip time of one destination (or of all, for broadcasts)."""

    initial: float
    floor: float
    cap: float
    srtt: float | None = None
    rttvar: float = 0.0
    samples: int = 0

    def sample(self, rtt: float) -> None:
        """Account for one measured round trip (seconds)."""
        if rtt < 0:
            return
        self.samples += 1
        if self.srtt is None:
            self.srtt = rtt
            self.rttvar = rtt / 2
            return
        self.rttvar = 0.75 * self.rttvar + 0.25 * abs(self.srtt - rtt)
        self.srtt = 0.875 * self.srtt + 0.125 * rtt

    @property
    def timeout(self) -> float:
        """The first retransmission delay to use now."""
        if self.srtt is None:
            return self.initial
        return min(self.cap, max(self.floor, self.srtt + max(4 * self.rttvar, self.floor)))
