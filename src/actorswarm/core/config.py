"""Protocol timings and limits of the collective core.

Every number the protocol uses lives here, with the defaults of docs/design.md §3, and is validated
when the config is built: a bad value raises :class:`ConfigError` naming the field, the value
and the rule, so a typo in a config file never turns into a swarm that silently misbehaves.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Literal

DetectorKind = Literal["timeout", "phi"]
MembershipKind = Literal["star", "broadcast"]


class ConfigError(ValueError):
    """A configuration value is out of range or inconsistent. The message names the field."""


@dataclass(frozen=True, slots=True, kw_only=True)
class CoreConfig:
    """Timings (seconds) and limits of one platform's collective core.

    Membership (docs/design.md §3.1): a heartbeat every ``heartbeat_interval``; a peer joins after
    ``join_heartbeats`` heartbeats within ``t_join``; it leaves after ``t_leave`` without one
    (``detector="timeout"``) or when the phi accrual suspicion passes ``phi_threshold``
    (``detector="phi"``).

    Topology (§3.1): ``membership="star"`` (the default) has a member that follows a live
    master heartbeat to the master only, while the master broadcasts its heartbeat with the
    roster version, its recent changes and a succession list of the next ``succession``
    lowest IDs; a member that is behind fetches the roster in chunks of ``roster_chunk``
    entries. ``"broadcast"`` is the paper's scheme: everyone broadcasts, everyone watches
    everyone.

    Suspicion (§3.1): a peer silent for its timeout is *suspected* and probed (listed in the
    watcher's heartbeats and asked directly every ``probe_interval``); it leaves when the
    probes have failed for at least ``probe_window`` and its silence exceeds what the view's
    size and the measured loss make likely for a live peer: the timeout is chosen so that a
    watcher declares a live peer gone at most ``false_leave_rate`` times a second. A star
    master whose measured loss reaches ``fast_master_loss`` (None: never; not on a shared
    channel) heartbeats twice per ``heartbeat_interval`` until it falls below two thirds of
    that, and says so in its heartbeats: its members, watching it alone, need half the time
    to tell its silence from loss, so a failover under heavy loss takes about half as long.

    Airtime (§3.1): with ``channel_bitrate`` (bit/s of the shared radio) set, the master
    slows its members' heartbeats so that they use at most ``heartbeat_share`` of the channel
    (``heartbeat_bits`` per heartbeat on the air), never faster than ``heartbeat_interval``.

    Wake-ups: with ``heartbeat_slack`` a heartbeat due within that many seconds goes out
    at a :meth:`~actorswarm.core.node.Node.tick` the host makes anyway (a packet woke it),
    instead of at a wake of its own, keeping its schedule's phase. A star member that
    follows a live master rides on its master's heartbeats (the wakes they cause) within a
    slack either side of its phase, since those come up to a slack early or late; a
    heartbeat that needed a wake of its own moves its phase half a slack later, until they
    ride. The rate stays one per cadence however often the host wakes; a gap is off the
    cadence by at most two slacks. A real
    daemon, whose every wake costs CPU, sets it when the configuration does not
    (``actorswarm.daemon.config``); the default, None (0), sends every heartbeat exactly
    on its schedule.

    Election (§3.2): a platform that has been up for ``boot_wait`` and sees no live master
    claims the role when it has the lowest ID in its view. ``takeover_on_join`` restores the
    paper's behaviour: a lower ID that joins always takes the role over. A new master's
    handshake ends when every member reported, or after ``handshake_timeout``. A barrier
    request made in an older epoch than the master's, for a generation no firing of its own
    epoch is known of, waits up to ``doubt_timeout`` for a report of a firing (from the other
    side of a healed partition) that may have chosen it, before it is called stale.

    Reliable delivery (§3.3): a message is retransmitted after ``base + k * retry_step``
    seconds (k = retries so far), capped at ``retry_cap``; a message not acknowledged within
    ``delivery_deadline`` fails visibly. ``base`` is ``retry_base`` — or, with
    ``adaptive_retry``, the timeout measured from the round trips to that destination
    (smoothed RTT + 4 × its variation, at least ``retry_min``), ``retry_base`` until the
    first measurement. The defaults suit round trips well under 30 ms (the benchmark's
    radio); on a slower radio raise ``retry_base`` or turn ``adaptive_retry`` on (measured
    in docs/benchmarks/core.md: with few round trips to learn from, it is slower there).
    """

    heartbeat_interval: float = 0.1
    membership: MembershipKind = "star"
    succession: int = 4
    roster_chunk: int = 1024
    probe_window: float = 0.06
    probe_interval: float = 0.05
    false_leave_rate: float = 1.0 / 3600.0
    fast_master_loss: float | None = 0.15
    channel_bitrate: float | None = None
    heartbeat_share: float = 0.5
    heartbeat_bits: int = 800
    heartbeat_slack: float | None = None
    join_heartbeats: int = 3
    t_join: float = 1.0
    t_leave: float = 0.5
    detector: DetectorKind = "timeout"
    phi_threshold: float = 8.0
    phi_window: int = 100
    phi_min_std: float = 0.02
    takeover_on_join: bool = False
    boot_wait: float | None = None
    handshake_timeout: float = 2.0
    doubt_timeout: float = 5.0
    retry_base: float = 0.03
    retry_step: float = 0.01
    retry_cap: float = 0.2
    retry_min: float = 0.01
    adaptive_retry: bool = False
    delivery_deadline: float = 10.0
    window: int = 32
    max_packet_bytes: int = 60_000
    release_chunk: int = 256

    def __post_init__(self) -> None:
        self._check_types()
        positive = (
            "heartbeat_interval",
            "t_join",
            "t_leave",
            "phi_threshold",
            "phi_min_std",
            "retry_base",
            "retry_cap",
            "retry_min",
            "delivery_deadline",
            "handshake_timeout",
            "doubt_timeout",
            "probe_window",
            "probe_interval",
            "false_leave_rate",
        )
        for name in positive:
            value = getattr(self, name)
            if not isinstance(value, int | float) or isinstance(value, bool):
                raise ConfigError(f"{name}: expected a number, got {value!r}")
            if not math.isfinite(value) or value <= 0:
                raise ConfigError(f"{name}: must be a positive finite number, got {value!r}")
        if self.retry_step < 0 or not math.isfinite(self.retry_step):
            raise ConfigError(f"retry_step: must be >= 0, got {self.retry_step!r}")
        if self.retry_min > self.retry_cap:
            raise ConfigError(
                f"retry_min ({self.retry_min}) must be <= retry_cap ({self.retry_cap})"
            )
        if self.retry_cap < self.retry_base:
            raise ConfigError(
                f"retry_cap ({self.retry_cap}) must be >= retry_base ({self.retry_base})"
            )
        for name, low in (
            ("join_heartbeats", 1),
            ("phi_window", 2),
            ("window", 1),
            ("max_packet_bytes", 512),
            ("release_chunk", 1),
            ("succession", 1),
            ("roster_chunk", 16),
            ("heartbeat_bits", 64),
        ):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < low:
                raise ConfigError(f"{name}: must be an integer >= {low}, got {value!r}")
        if self.membership not in ("star", "broadcast"):
            raise ConfigError(f"membership: must be 'star' or 'broadcast', got {self.membership!r}")
        if self.channel_bitrate is not None and (
            not math.isfinite(self.channel_bitrate) or self.channel_bitrate <= 0
        ):
            raise ConfigError(
                "channel_bitrate: must be a positive bit rate or None, "
                f"got {self.channel_bitrate!r}"
            )
        fast = self.fast_master_loss
        number = isinstance(fast, float | int) and not isinstance(fast, bool)
        if fast is not None and not (number and 0 < fast < 1):
            raise ConfigError(f"fast_master_loss: must be in (0, 1) or None, got {fast!r}")
        if not 0 < self.heartbeat_share <= 1:
            raise ConfigError(f"heartbeat_share: must be in (0, 1], got {self.heartbeat_share!r}")
        slack = self.heartbeat_slack
        if slack is not None and not 0 <= slack <= self.heartbeat_interval / 2:
            raise ConfigError(
                f"heartbeat_slack: must be in [0, heartbeat_interval / 2 = "
                f"{self.heartbeat_interval / 2:g}], got {slack!r}"
            )
        if self.detector not in ("timeout", "phi"):
            raise ConfigError(f"detector: must be 'timeout' or 'phi', got {self.detector!r}")
        if self.t_leave <= self.heartbeat_interval:
            raise ConfigError(
                f"t_leave ({self.t_leave}) must exceed heartbeat_interval "
                f"({self.heartbeat_interval}), or every peer would leave between two heartbeats"
            )
        needed = (self.join_heartbeats - 1) * self.heartbeat_interval
        if self.t_join < needed:
            raise ConfigError(
                f"t_join ({self.t_join}) is shorter than {self.join_heartbeats} heartbeats "
                f"take to arrive ({needed:.3g} s): no peer could ever join"
            )
        if self.boot_wait is not None and (not math.isfinite(self.boot_wait) or self.boot_wait < 0):
            raise ConfigError(f"boot_wait: must be >= 0, got {self.boot_wait!r}")

    def _check_types(self) -> None:
        """Refuse values of the wrong type by field name (``"no"`` is not a boolean)."""
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            kind = str(f.type)
            if kind == "bool":
                ok = isinstance(value, bool)
            elif kind == "int":
                ok = isinstance(value, int) and not isinstance(value, bool)
            elif kind in ("DetectorKind", "MembershipKind"):
                ok = isinstance(value, str)
            else:  # float, optionally None
                ok = (value is None and "None" in kind) or (
                    isinstance(value, int | float) and not isinstance(value, bool)
                )
            if not ok:
                raise ConfigError(f"{f.name}: expected {kind}, got {value!r}")

    @property
    def startup_wait(self) -> float:
        """How long a fresh platform listens before it may claim mastership.

        Long enough for the peers' heartbeats to make them join (``join_heartbeats``
        intervals plus one of slack), so a rebooted low-ID platform learns of a healthy master
        before it would claim the role.
        """
        if self.boot_wait is not None:
            return self.boot_wait
        return (self.join_heartbeats + 1) * self.heartbeat_interval

    def retry_delay(self, retries: int, base: float | None = None) -> float:
        """Delay before the next retransmission after ``retries`` earlier ones (linear, capped);
        ``base`` is the first delay (default ``retry_base``)."""
        first = self.retry_base if base is None else base
        return min(first + retries * self.retry_step, self.retry_cap)

    def replace(self, **changes: Any) -> CoreConfig:
        """A copy with ``changes`` applied (and validated)."""
        return dataclasses.replace(self, **changes)

    @classmethod
    def from_mapping(cls, values: dict[str, Any]) -> CoreConfig:
        """Build from a config-file table, refusing unknown keys by name."""
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(values) - known)
        if unknown:
            raise ConfigError(
                f"unknown core setting(s): {', '.join(unknown)}; known: {', '.join(sorted(known))}"
            )
        if values.get("fast_master_loss") is False:  # TOML has no None: false means never
            values = {**values, "fast_master_loss": None}
        try:
            return cls(**values)
        except TypeError as exc:  # wrong type that dataclasses itself refuses
            raise ConfigError(str(exc)) from exc
