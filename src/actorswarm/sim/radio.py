"""The simulated radio: unicast and broadcast between platforms, in virtual time, with faults.

Theory of operation
-------------------
Platforms :meth:`~SimRadio.attach` a delivery callback. :meth:`SimRadio.send` happens at the
scheduler's current time; it decides at once, for each receiver, whether the packet is lost
and when it arrives, and schedules the deliveries on the :class:`~actorswarm.sim.scheduler.
Scheduler`. Nothing is decided later except the two things that can change while a packet is
in flight: whether the receiver is still attached and whether a partition now separates it
from the sender (both are checked again at delivery).

Each sent packet becomes one :class:`Transmission`, shared by all its receivers. Its
:meth:`~Transmission.packet` decodes the bytes on first use and caches the result, so a
broadcast heard by 999 platforms is decoded once, not 999 times. Receivers whose delivery
times are equal are served by one scheduler event, in ascending platform order: without
jitter, reordering or duplication a broadcast costs one event, whatever the size of the
swarm. When delivery times differ, the deliveries are sorted by (time, platform) and walked
by a chain of events — each delivers the receivers due at its time and schedules the next —
so the scheduler's heap holds one entry per packet in flight, not one per receiver.

Faults (:class:`LinkModel`) are drawn from the radio's own ``random.Random`` in a fixed
order — receivers in ascending platform order, and for each: burst state, burst loss,
independent loss, jitter, reordering, corruption, duplication (and the copy's corruption) —
and a draw is made only when its probability is non-zero. The same seed, model and sequence
of calls therefore give the same run, event for event.

With a ``bandwidth``, each sender has one transmitter: a packet occupies it for
``len / bandwidth`` seconds after the packets queued before it, and arrives ``latency`` after
its transmission ends. A platform detached while packets are still queued in its
transmitter never puts them on the air.

With an :class:`Airtime` (:attr:`SimRadio.airtime`), every platform shares one channel — one
collision domain — of a given bitrate: each transmission, a broadcast once like a unicast,
occupies it for :meth:`Airtime.seconds` of its size. The channel serves packets first come,
first served, in the order they are sent: one "channel free at" time is all the state there
is, so the model costs O(1) per packet. A packet starts when the channel is free, arrives
its airtime plus the link's latency later, and is dropped instead if it would have to wait
longer than :attr:`Airtime.max_queue_s` for the channel. It does not model collisions,
hidden terminals, capture, carrier sensing or backoff: access is a perfect FIFO. With a
``bandwidth`` as well, the channel's queue takes the place of each sender's transmitter (it
serializes everything already) and a sender whose ``bandwidth`` is below the channel's
bitrate holds the channel for ``len / bandwidth`` instead, as a slow station does. A platform
that detaches loses the packets it still had queued, as without airtime, but the channel time
they were given stays taken (freeing it would mean moving every packet queued behind them).

Traffic is counted per platform and per packet kind (:class:`Traffic`): a transmission counts
once at its sender, and once at each receiver when actually delivered. Packets that are not
delivered are counted by cause in :attr:`SimRadio.drops`. The load on the channel — packets
and bits put on the air, airtime and waits, drops for want of airtime — is counted whether
or not airtime is modelled, and read with :meth:`SimRadio.channel_stats`.
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable, Iterable, KeysView, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Final, Generic, TypeVar

from actorswarm.sim.scheduler import Scheduler

__all__ = [
    "DROP_CAUSES",
    "Airtime",
    "ChannelStats",
    "GilbertElliott",
    "LinkModel",
    "SimRadio",
    "Traffic",
    "Transmission",
]

P = TypeVar("P")

#: Causes under which :attr:`SimRadio.drops` counts packets that were not delivered.
DROP_CAUSES: Final = ("loss", "burst", "partition", "detached", "range", "airtime")

# Group of every platform that no partition group names (see SimRadio.partition).
_REST: Final = -1
_UNSET: Final[Any] = object()


def _check_probability(owner: str, name: str, value: float) -> None:
    if not 0.0 <= value <= 1.0:
        raise ValueError(f"{owner}.{name} must be a probability in [0, 1], got {value!r}")


def _check_duration(owner: str, name: str, value: float) -> None:
    if not 0.0 <= value < math.inf:
        raise ValueError(f"{owner}.{name} must be a finite number of seconds >= 0, got {value!r}")


@dataclass(frozen=True, slots=True, kw_only=True)
class GilbertElliott:
    """Bursty loss: a two-state (good/bad) Markov chain per directed link.

    A link starts good. For every packet on the link the chain first steps (good to bad with
    probability ``p_good_to_bad``, bad to good with ``p_bad_to_good``), then the packet is
    lost with ``loss_good`` or ``loss_bad`` depending on the new state. The mean length of a
    bad period is ``1 / p_bad_to_good`` packets.
    """

    p_good_to_bad: float
    p_bad_to_good: float
    loss_good: float = 0.0
    loss_bad: float = 1.0

    def __post_init__(self) -> None:
        for name in ("p_good_to_bad", "p_bad_to_good", "loss_good", "loss_bad"):
            _check_probability("GilbertElliott", name, getattr(self, name))

    @property
    def mean_loss(self) -> float:
        """Long-run loss rate of the chain (0 when it never leaves the good state)."""
        total = self.p_good_to_bad + self.p_bad_to_good
        if total == 0.0:
            return self.loss_good
        bad = self.p_good_to_bad / total
        return bad * self.loss_bad + (1.0 - bad) * self.loss_good


@dataclass(frozen=True, slots=True, kw_only=True)
class LinkModel:
    """How the simulated radio treats every packet; the same for every directed link.

    ``loss``: independent probability that a receiver misses a packet. ``latency``: one-way
    delay, seconds. ``jitter``: extra delay drawn uniformly in ``[0, jitter]`` per receiver.
    ``reorder``: probability of an extra delay drawn in ``[0, reorder_delay]``, which lets
    later packets overtake this one. ``duplicate``: probability that a delivered packet is
    delivered a second time, the copy delayed by an extra ``[0, reorder_delay]``. ``burst``:
    bursty loss per directed link, applied before ``loss``. ``bandwidth``: bytes per second
    of each sender's transmitter (None: unlimited). ``corrupt``: probability that the bytes
    a receiver gets are damaged (bits flipped or the packet truncated).
    """

    loss: float = 0.0
    latency: float = 0.01
    jitter: float = 0.0
    duplicate: float = 0.0
    reorder: float = 0.0
    reorder_delay: float = 0.05
    burst: GilbertElliott | None = None
    bandwidth: float | None = None
    corrupt: float = 0.0

    def __post_init__(self) -> None:
        for name in ("loss", "duplicate", "reorder", "corrupt"):
            _check_probability("LinkModel", name, getattr(self, name))
        for name in ("latency", "jitter", "reorder_delay"):
            _check_duration("LinkModel", name, getattr(self, name))
        if self.bandwidth is not None and not 0.0 < self.bandwidth < math.inf:
            raise ValueError(
                f"LinkModel.bandwidth must be None or a finite number of bytes/s > 0, "
                f"got {self.bandwidth!r}"
            )

    @property
    def faultless(self) -> bool:
        """True when no packet is ever lost, delayed unevenly, duplicated or corrupted."""
        return (
            self.loss == 0.0
            and self.jitter == 0.0
            and self.duplicate == 0.0
            and self.reorder == 0.0
            and self.burst is None
            and self.corrupt == 0.0
        )


@dataclass(frozen=True, slots=True, kw_only=True)
class Airtime:
    """The shared channel every platform transmits on (see the module docstring).

    ``bitrate``: bits per second of the channel, finite and > 0. ``overhead_bytes``: bytes
    each packet carries on the air besides its payload (the default, 28, is the IPv4 and UDP
    headers; add the link layer's framing and preamble to taste). ``max_queue_s``: the
    longest a packet may wait for the channel before it starts; one that would wait longer
    is dropped (``math.inf``: never drop, the queue grows without bound; 0: drop whatever
    finds the channel busy). ``ValueError``, naming the field, for an invalid value.
    """

    bitrate: float
    overhead_bytes: int = 28
    max_queue_s: float = 1.0

    def __post_init__(self) -> None:
        if not 0.0 < self.bitrate < math.inf:
            raise ValueError(
                f"Airtime.bitrate must be a finite number of bits/s > 0, got {self.bitrate!r}"
            )
        overhead = self.overhead_bytes
        if isinstance(overhead, bool) or not isinstance(overhead, int) or overhead < 0:
            raise ValueError(
                f"Airtime.overhead_bytes must be an integer number of bytes >= 0, got {overhead!r}"
            )
        # Unlike the link model's durations, an infinite queue is allowed (nothing dropped).
        if not 0.0 <= self.max_queue_s <= math.inf:
            raise ValueError(
                f"Airtime.max_queue_s must be a number of seconds >= 0 (inf allowed), "
                f"got {self.max_queue_s!r}"
            )

    def seconds(self, size: int) -> float:
        """How long a packet of ``size`` payload bytes occupies the channel."""
        return (size + self.overhead_bytes) * 8 / self.bitrate


@dataclass(frozen=True, slots=True, kw_only=True)
class ChannelStats:
    """The load on the radio's channel over a window of virtual time (a snapshot).

    The window runs from ``start_s`` (0, or the last :meth:`SimRadio.reset_channel_stats`)
    to the snapshot, ``elapsed_s`` seconds. A packet counts when it is sent, and a broadcast
    counts once, however many hear it; a packet from a platform that is not attached is not
    sent and does not count.

    ``packets`` and ``bits``: put on the air (a unicast to a platform that is not attached
    too: the sender transmits all the same). ``bits`` is 8 × the payload bytes, plus
    ``overhead_bytes`` per packet sent while airtime was modelled. ``packets_per_s`` and
    ``bits_per_s``: those over ``elapsed_s`` (0 when no time elapsed). ``bitrate``: the
    channel's while airtime is modelled, else None. ``busy_s``: time within the window the
    channel was occupied (0 when airtime is not modelled). ``utilisation``: ``busy_s /
    elapsed_s``, in [0, 1] (None when airtime is not modelled, 0 when no time elapsed).
    ``drops``: packets never put on the air because they would have waited longer than
    ``max_queue_s``, each counted once (:attr:`SimRadio.drops` counts them per receiver);
    ``drops_by_kind``: the same per packet kind, kinds sorted (read-only).
    ``max_queue_delay_s``: the longest a packet put on the air waited for the channel (0
    when airtime is not modelled). ``relayed``: of ``packets``, the transmissions of relays
    sending packets on (:attr:`SimRadio.relay_fn`: a world whose radio relays); they count
    in ``bits`` and hold the channel too. Packets sent in the window
    whose airtime falls after it count in ``packets``, ``bits`` and the queueing figures
    but not in ``busy_s``.
    """

    start_s: float
    elapsed_s: float
    packets: int
    bits: int
    packets_per_s: float
    bits_per_s: float
    bitrate: float | None
    busy_s: float
    utilisation: float | None
    drops: int
    drops_by_kind: Mapping[str, int]
    max_queue_delay_s: float
    relayed: int

    def as_dict(self) -> dict[str, Any]:
        """Plain, JSON-ready data: every field under its own name (``drops_by_kind`` a dict)."""
        return {
            "start_s": self.start_s,
            "elapsed_s": self.elapsed_s,
            "packets": self.packets,
            "bits": self.bits,
            "packets_per_s": self.packets_per_s,
            "bits_per_s": self.bits_per_s,
            "bitrate": self.bitrate,
            "busy_s": self.busy_s,
            "utilisation": self.utilisation,
            "drops": self.drops,
            "drops_by_kind": dict(self.drops_by_kind),
            "max_queue_delay_s": self.max_queue_delay_s,
            "relayed": self.relayed,
        }


class Transmission(Generic[P]):
    """One packet on the air, as handed to every receiver's delivery callback.

    ``data`` are the bytes as sent — or, when ``corrupted`` is true, the damaged bytes this
    one receiver got (a corrupted delivery is a Transmission of its own). ``dst`` is None for
    a broadcast. Treat a Transmission as read-only: it is shared by all receivers.
    """

    __slots__ = ("_decoder", "_end", "_epoch", "_packet", "corrupted", "data", "dst", "kind", "src")

    def __init__(
        self,
        src: int,
        dst: int | None,
        kind: str,
        data: bytes,
        decoder: Callable[[bytes], P],
        *,
        corrupted: bool = False,
        epoch: int = 0,
        end: float = 0.0,
    ) -> None:
        self.src = src
        self.dst = dst
        self.kind = kind
        self.data = data
        self.corrupted = corrupted
        self._decoder = decoder
        self._packet: Any = _UNSET
        # Sender's attach epoch and end of transmission: a packet still in the transmitter
        # when its sender detaches is never put on the air.
        self._epoch = epoch
        self._end = end

    def packet(self) -> P:
        """``data`` decoded with the radio's decoder; decoded once, then cached.

        Raises whatever the decoder raises (the same exception again on later calls).
        """
        cached = self._packet
        if cached is _UNSET:
            try:
                cached = self._packet = self._decoder(self.data)
            except Exception as exc:
                self._packet = _Failed(exc)
                raise
        if isinstance(cached, _Failed):
            raise cached.exc.with_traceback(None)
        result: P = cached
        return result

    def __repr__(self) -> str:
        flag = ", corrupted" if self.corrupted else ""
        return (
            f"Transmission(src={self.src}, dst={self.dst}, kind={self.kind!r}, "
            f"{len(self.data)} bytes{flag})"
        )


class _Failed:
    """A cached decoding failure (so a broadcast of bad bytes is also decoded only once)."""

    __slots__ = ("exc",)

    def __init__(self, exc: Exception) -> None:
        self.exc = exc


_ROW_KEYS: Final = ("sent_packets", "sent_bytes", "recv_packets", "recv_bytes")


class Traffic:
    """Packet and byte counters per platform, and per platform and packet kind.

    Each counter row is ``[sent_packets, sent_bytes, recv_packets, recv_bytes]``. Sending is
    counted once per transmission at the sender (a broadcast too); receiving is counted at
    each receiver when the packet is actually delivered (a duplicate counts twice).
    """

    __slots__ = ("_kinds", "_rows")

    def __init__(self) -> None:
        self._rows: dict[int, list[int]] = {}
        self._kinds: dict[str, dict[int, list[int]]] = {}

    def count_sent(self, platform: int, kind: str, size: int) -> None:
        """Count one packet of ``size`` bytes sent by ``platform``."""
        row = self._rows.get(platform)
        if row is None:
            row = self._rows[platform] = [0, 0, 0, 0]
        row[0] += 1
        row[1] += size
        rows = self._kind_rows(kind)
        row = rows.get(platform)
        if row is None:
            row = rows[platform] = [0, 0, 0, 0]
        row[0] += 1
        row[1] += size

    def count_received(self, platform: int, kind: str, size: int) -> None:
        """Count one packet of ``size`` bytes delivered to ``platform``."""
        row = self._rows.get(platform)
        if row is None:
            row = self._rows[platform] = [0, 0, 0, 0]
        row[2] += 1
        row[3] += size
        rows = self._kind_rows(kind)
        row = rows.get(platform)
        if row is None:
            row = rows[platform] = [0, 0, 0, 0]
        row[2] += 1
        row[3] += size

    def _kind_rows(self, kind: str) -> dict[int, list[int]]:
        rows = self._kinds.get(kind)
        if rows is None:
            rows = self._kinds[kind] = {}
        return rows

    def totals(self, platform: int) -> tuple[int, int, int, int]:
        """``(sent_packets, sent_bytes, recv_packets, recv_bytes)`` of one platform."""
        row = self._rows.get(platform)
        if row is None:
            return (0, 0, 0, 0)
        return (row[0], row[1], row[2], row[3])

    def kind_totals(self, kind: str) -> tuple[int, int, int, int]:
        """The same four counters for one packet kind, summed over all platforms."""
        sums = [0, 0, 0, 0]
        for row in self._kinds.get(kind, {}).values():
            for i in range(4):
                sums[i] += row[i]
        return (sums[0], sums[1], sums[2], sums[3])

    @property
    def platforms(self) -> list[int]:
        """Platforms that sent or received anything, ascending."""
        return sorted(self._rows)

    @property
    def kinds(self) -> list[str]:
        """Packet kinds seen so far, sorted."""
        return sorted(self._kinds)

    def snapshot(self) -> dict[int, dict[str, Any]]:
        """Plain-data copy of every counter, platforms ascending, kinds sorted::

        {platform: {"sent_packets": n, "sent_bytes": n, "recv_packets": n, "recv_bytes": n,
                    "by_kind": {kind: {the same four keys}}}}
        """
        out: dict[int, dict[str, Any]] = {}
        for platform in sorted(self._rows):
            entry: dict[str, Any] = dict(zip(_ROW_KEYS, self._rows[platform], strict=True))
            by_kind: dict[str, dict[str, int]] = {}
            for kind in sorted(self._kinds):
                row = self._kinds[kind].get(platform)
                if row is not None:
                    by_kind[kind] = dict(zip(_ROW_KEYS, row, strict=True))
            entry["by_kind"] = by_kind
            out[platform] = entry
        return out


class SimRadio(Generic[P]):
    """The shared medium of a simulated swarm. See the module docstring.

    ``decoder`` turns the bytes of a :class:`Transmission` into its packet (for the core:
    ``actorswarm.core.wire.decode``). ``rng`` is used for every fault and nothing else should
    draw from it if runs are to be reproducible. ``tap``, when set, is called on every send
    from an attached platform as ``tap(now, src, dst, kind, size)``. ``airtime``: the
    shared channel to model (:attr:`airtime`); None, the default, models none.
    """

    __slots__ = (
        "_air_bytes",
        "_air_drops",
        "_air_packets",
        "_air_relayed",
        "_air_since",
        "_air_wait",
        "_airtime",
        "_bad_links",
        "_burst",
        "_busy",
        "_chan_free",
        "_epochs",
        "_fast",
        "_group",
        "_handlers",
        "_left",
        "_model",
        "_order",
        "_sched",
        "_tx_free",
        "decoder",
        "drops",
        "link_fn",
        "relay_fn",
        "rng",
        "tap",
        "traffic",
    )

    def __init__(
        self,
        scheduler: Scheduler,
        rng: random.Random,
        model: LinkModel,
        *,
        decoder: Callable[[bytes], P],
        airtime: Airtime | None = None,
    ) -> None:
        self._sched = scheduler
        self.rng = rng
        self.decoder = decoder
        self.traffic = Traffic()
        self.drops: dict[str, int] = dict.fromkeys(DROP_CAUSES, 0)
        self.tap: Callable[[float, int, int | None, str, int], None] | None = None
        #: Optional per-link model ``link_fn(src, dst) -> (loss probability, extra latency)``
        #: drawn for each receiver on top of the link model — the world's radio model, so a
        #: platform that flies out of range really drops out. None: every link is alike.
        self.link_fn: Callable[[int, int], tuple[float, float]] | None = None
        #: Optional ``relay_fn(src, dst)``: how many times relays send on a packet from
        #: ``src`` to ``dst`` (None: a broadcast) — the world's relayed routes. Each is one
        #: more transmission on the air (channel time, packets and bits). None: no relays.
        self.relay_fn: Callable[[int, int | None], int] | None = None
        self._handlers: dict[int, Callable[[Transmission[P], float], None]] = {}
        # Attached platforms ascending, rebuilt lazily after attach/detach. A broadcast keeps
        # the tuple of its send time, so later attach/detach never disturbs one in flight.
        self._order: tuple[int, ...] | None = None
        self._epochs: dict[int, int] = {}
        self._left: dict[tuple[int, int], float] = {}
        self._tx_free: dict[int, float] = {}
        # Partition group per platform; empty when the swarm is whole.
        self._group: dict[int, int] = {}
        # Directed links currently in the bad state of the Gilbert-Elliott chain.
        self._bad_links: set[tuple[int, int]] = set()
        self._model = model
        self._burst = model.burst
        self._fast = model.faultless
        # The shared channel: when it is next free, and the counters behind channel_stats().
        # Packets and bytes on the air are counted even without airtime: that is the load.
        self._airtime = airtime
        self._chan_free = 0.0
        self._air_since = scheduler.now
        self._air_packets = 0
        self._air_bytes = 0
        self._air_relayed = 0
        self._air_wait = 0.0
        self._air_drops: dict[str, int] = {}
        # Channel time of the packets sent in the window, plus what was still reserved
        # when it began (see reset_channel_stats).
        self._busy = 0.0

    # --- configuration ------------------------------------------------------------------

    @property
    def model(self) -> LinkModel:
        """The link model; may be replaced mid-run (applies to packets sent from then on)."""
        return self._model

    @model.setter
    def model(self, model: LinkModel) -> None:
        self._model = model
        self._burst = model.burst
        self._fast = model.faultless

    @property
    def airtime(self) -> Airtime | None:
        """The shared channel modelled, or None (no airtime: packets never wait for one).

        May be set mid-run; applies to packets sent from then on. Packets already queued
        keep their place, and a channel set again later is busy until they are through.
        """
        return self._airtime

    @airtime.setter
    def airtime(self, airtime: Airtime | None) -> None:
        self._airtime = airtime

    @property
    def scheduler(self) -> Scheduler:
        return self._sched

    # --- channel load -------------------------------------------------------------------

    def channel_stats(self) -> ChannelStats:
        """The channel's load since the window began (see :class:`ChannelStats`)."""
        now = self._sched.now
        elapsed = now - self._air_since
        airtime = self._airtime
        # Channel time reserved for packets sent in the window, less the part still ahead:
        # every packet starting after now follows the one before it back to back, so the
        # channel is busy without a gap from now to _chan_free.
        busy = max(0.0, self._busy - max(0.0, self._chan_free - now))
        bits = 8 * self._air_bytes
        drops = dict(sorted(self._air_drops.items()))
        # Capped: summing many airtimes can round a hair above the elapsed time.
        share = min(1.0, busy / elapsed) if elapsed > 0 else 0.0
        utilisation = None if airtime is None else share
        return ChannelStats(
            start_s=self._air_since,
            elapsed_s=elapsed,
            packets=self._air_packets,
            relayed=self._air_relayed,
            bits=bits,
            packets_per_s=self._air_packets / elapsed if elapsed > 0 else 0.0,
            bits_per_s=bits / elapsed if elapsed > 0 else 0.0,
            bitrate=None if airtime is None else airtime.bitrate,
            busy_s=busy,
            utilisation=utilisation,
            drops=sum(drops.values()),
            drops_by_kind=MappingProxyType(drops),
            max_queue_delay_s=self._air_wait,
        )

    def reset_channel_stats(self) -> None:
        """Start a new window of :meth:`channel_stats` now (every figure back to zero).

        A benchmark calls it once the swarm has formed, to measure the steady state.
        """
        now = self._sched.now
        self._air_since = now
        self._air_packets = 0
        self._air_bytes = 0
        self._air_relayed = 0
        self._air_wait = 0.0
        self._air_drops = {}
        # Channel time already reserved beyond now belongs to the new window.
        self._busy = max(0.0, self._chan_free - now)

    # --- platforms ----------------------------------------------------------------------

    def attach(self, platform: int, deliver: Callable[[Transmission[P], float], None]) -> None:
        """Put ``platform`` on the air: ``deliver(transmission, now)`` receives its packets.

        ``ValueError`` if it is already attached. Re-attaching after :meth:`detach` is a
        reboot; packets the old incarnation left in its transmitter are gone.
        """
        if platform in self._handlers:
            raise ValueError(f"platform {platform} is already attached")
        self._handlers[platform] = deliver
        self._epochs[platform] = self._epochs.get(platform, 0) + 1
        self._order = None

    def detach(self, platform: int) -> bool:
        """Take ``platform`` off the air (a crash). False if it was not attached.

        From now on it neither sends nor receives; packets in flight to it are dropped when
        they arrive, and packets still queued in its transmitter are never sent. (Delivery
        only asks whether the receiver is attached at that moment: a platform re-attached
        before a packet in flight arrives does receive it, as a rebooted radio would.)
        """
        if self._handlers.pop(platform, None) is None:
            return False
        self._left[(platform, self._epochs[platform])] = self._sched.now
        self._tx_free.pop(platform, None)
        self._order = None
        return True

    @property
    def attached(self) -> KeysView[int]:
        """Live, read-only view of the attached platforms."""
        return self._handlers.keys()

    def _sorted(self) -> tuple[int, ...]:
        order = self._order
        if order is None:
            order = self._order = tuple(sorted(self._handlers))
        return order

    # --- partitions ---------------------------------------------------------------------

    def partition(self, groups: Iterable[Iterable[int]]) -> None:
        """Split the swarm: platforms in different groups cannot hear each other.

        Replaces any previous partition. Platforms named in no group form one more group
        together. ``ValueError`` if a platform is named in two groups.
        """
        assignment: dict[int, int] = {}
        for index, group in enumerate(groups):
            for platform in group:
                previous = assignment.setdefault(platform, index)
                if previous != index:
                    raise ValueError(
                        f"platform {platform} is in partition groups {previous} and {index}"
                    )
        self._group = assignment

    def heal(self) -> None:
        """Remove every partition."""
        self._group = {}

    def connected(self, a: int, b: int) -> bool:
        """True when no partition separates ``a`` and ``b`` (attachment is not considered)."""
        group = self._group
        return group.get(a, _REST) == group.get(b, _REST)

    def components(self, platforms: Iterable[int]) -> list[frozenset[int]]:
        """The given platforms split into groups that can hear each other.

        Sorted by smallest member; platforms given twice count once. With a per-link model
        (:attr:`link_fn`), a group connected hop by hop whose members do not all hear each
        other (loss 1 between two of them: out of range, and nobody relays) is no stable
        network: it counts as each of its platforms alone, so that the invariants of a
        connected swarm (one master, all-or-nothing releases) are not asked of it. A world
        whose radio relays answers for the relayed path, so its groups hear each other.
        """
        by_group: dict[int, set[int]] = {}
        group = self._group
        for platform in platforms:
            by_group.setdefault(group.get(platform, _REST), set()).add(platform)
        if self.link_fn is None:
            return sorted((frozenset(members) for members in by_group.values()), key=min)
        # With a per-link model, a partition group splits further where links are out of
        # range (loss 1): components are what remains connected, hop by hop.
        link_fn = self.link_fn
        out: list[frozenset[int]] = []
        for members in by_group.values():
            left = set(members)
            while left:
                start = min(left)
                seen = {start}
                frontier = [start]
                left.discard(start)
                while frontier:
                    a = frontier.pop()
                    for b in sorted(left):
                        if link_fn(a, b)[0] < 1.0:
                            left.discard(b)
                            seen.add(b)
                            frontier.append(b)
                ordered = sorted(seen)
                if all(link_fn(a, b)[0] < 1.0 for i, a in enumerate(ordered)
                       for b in ordered[i + 1 :]):  # fmt: skip
                    out.append(frozenset(seen))
                else:
                    out.extend(frozenset((p,)) for p in ordered)
        return sorted(out, key=min)

    # --- sending ------------------------------------------------------------------------

    def send(self, src: int, dst: int | None, data: bytes, kind: str) -> None:
        """Put ``data`` on the air from ``src`` at the scheduler's current time.

        ``dst`` None broadcasts to every attached platform but ``src``. ``kind`` labels the
        packet in the traffic counters. A packet from a platform that is not attached is not
        sent (it counts as a ``detached`` drop). A unicast to a platform that is not attached
        counts as sent and is dropped. With :attr:`airtime`, a packet that would wait longer
        than ``max_queue_s`` for the channel counts as sent and is dropped (cause
        ``airtime``). ``ValueError`` if ``dst == src``: a radio does not hear itself.
        """
        handlers = self._handlers
        if src not in handlers:
            self.drops["detached"] += 1
            return
        if dst == src:
            raise ValueError(f"platform {src} cannot send a packet to itself")
        sched = self._sched
        now = sched.now
        size = len(data)
        if self.tap is not None:
            self.tap(now, src, dst, kind, size)
        self.traffic.count_sent(src, kind, size)

        model = self._model
        end = now
        relays = 0 if self.relay_fn is None else self.relay_fn(src, dst)
        if self._airtime is not None:
            on_air = self._channel(src, dst, size, kind, now, relays)
            if on_air is None:
                return
            end = on_air
        else:
            if model.bandwidth is not None:
                # One transmitter per sender: wait for the packets queued before this one.
                end = max(now, self._tx_free.get(src, now)) + size / model.bandwidth
                self._tx_free[src] = end
            self._air_packets += 1 + relays
            self._air_bytes += size * (1 + relays)
            self._air_relayed += relays
        tx = Transmission(src, dst, kind, data, self.decoder, epoch=self._epochs[src], end=end)
        arrival = end + model.latency

        if dst is None:
            receivers = self._sorted()
        elif dst in handlers:
            receivers = (dst,)
        else:
            self.drops["detached"] += 1
            return

        group = self._group
        if self._fast and not group and self.link_fn is None:
            # The common case: everyone hears it at the same time, so one event serves all.
            # ``receivers`` may contain src; delivery skips it.
            sched.call_at(arrival, self._deliver, tx, receivers)
            return
        self._send_faulty(tx, receivers, arrival)

    def _channel(
        self, src: int, dst: int | None, size: int, kind: str, now: float, relays: int
    ) -> float | None:
        """Queue a packet for the shared channel: when its transmission ends, or None if it
        is dropped because it would wait longer than ``max_queue_s`` (counted here). Its
        ``relays`` sending it on hold the channel right after it, once each: the packet is
        not delivered before its own transmission ends, but the channel stays taken."""
        airtime = self._airtime
        assert airtime is not None
        on_air = size + airtime.overhead_bytes
        duration = on_air * 8 / airtime.bitrate
        bandwidth = self._model.bandwidth
        if bandwidth is not None:
            # A sender slower than the channel holds it for as long as it takes to send.
            duration = max(duration, size / bandwidth)
        start = max(self._chan_free, now)
        wait = start - now
        if wait > airtime.max_queue_s:
            drops = self._air_drops
            drops[kind] = drops.get(kind, 0) + 1
            # Every would-be receiver misses it: per receiver, as the other causes count.
            self.drops["airtime"] += len(self._handlers) - 1 if dst is None else 1
            return None
        end = self._chan_free = start + duration
        if relays:
            # The relays' transmissions follow the packet's own: a simplification (a relay
            # sends on only once it has the packet; relays far apart could share the air).
            relayed = relays * on_air * 8 / airtime.bitrate
            self._chan_free = end + relayed
            self._busy += relayed
        if bandwidth is not None:
            # Keeps the sender's own queue right should airtime be switched off later.
            self._tx_free[src] = end
        self._busy += duration
        self._air_packets += 1 + relays
        self._air_bytes += on_air * (1 + relays)
        self._air_relayed += relays
        self._air_wait = max(self._air_wait, wait)
        return end

    def _send_faulty(self, tx: Transmission[P], receivers: tuple[int, ...], arrival: float) -> None:
        """Draw the faults of each receiver and schedule the deliveries (see module doc)."""
        model = self._model
        rng = self.rng
        random_ = rng.random
        drops = self.drops
        sched = self._sched
        src = tx.src
        group = self._group
        src_group = group.get(src, _REST)
        burst = self._burst
        bad_links = self._bad_links
        loss = model.loss
        jitter = model.jitter
        reorder = model.reorder
        reorder_delay = model.reorder_delay
        duplicate = model.duplicate
        corrupt = model.corrupt
        link_fn = self.link_fn
        # (arrival time, receiver) of every uncorrupted delivery, receivers ascending.
        arrivals: list[tuple[float, int]] = []
        add = arrivals.append

        for dst in receivers:
            if dst == src:
                continue
            if group and group.get(dst, _REST) != src_group:
                drops["partition"] += 1
                continue
            if burst is not None:
                link = (src, dst)
                bad = link in bad_links
                if bad:
                    if burst.p_bad_to_good and random_() < burst.p_bad_to_good:
                        bad = False
                        bad_links.discard(link)
                elif burst.p_good_to_bad and random_() < burst.p_good_to_bad:
                    bad = True
                    bad_links.add(link)
                p = burst.loss_bad if bad else burst.loss_good
                if p and random_() < p:
                    drops["burst"] += 1
                    continue
            if loss and random_() < loss:
                drops["loss"] += 1
                continue
            t = arrival
            if link_fn is not None:
                link_loss, link_latency = link_fn(src, dst)
                if link_loss >= 1.0 or (link_loss > 0.0 and random_() < link_loss):
                    drops["range"] += 1
                    continue
                t += link_latency
            if jitter:
                t += random_() * jitter
            if reorder and random_() < reorder:
                t += random_() * reorder_delay
            if corrupt and random_() < corrupt:
                sched.call_at(t, self._deliver, self._corrupted(tx), (dst,))
            else:
                add((t, dst))
            if duplicate and random_() < duplicate:
                t2 = t + random_() * reorder_delay
                if corrupt and random_() < corrupt:
                    sched.call_at(t2, self._deliver, self._corrupted(tx), (dst,))
                else:
                    add((t2, dst))

        if not arrivals:
            return
        if not (jitter or reorder or duplicate or link_fn):
            # Everyone at the same time (only losses differ between receivers): one event.
            sched.call_at(arrival, self._deliver, tx, [dst for _, dst in arrivals])
            return
        if len(arrivals) == 1:
            # One receiver (a unicast, most of a star swarm's packets): the chain's one
            # event is the delivery itself.
            t, dst = arrivals[0]
            sched.call_at(t, self._deliver, tx, (dst,))
            return
        # Different times: one chain of events that walks the arrivals in time order, so the
        # heap holds one entry per packet in flight rather than one per receiver.
        arrivals.sort()
        times = [t for t, _ in arrivals]
        dsts = [dst for _, dst in arrivals]
        sched.call_at(times[0], self._deliver_chain, tx, times, dsts, 0)

    def _corrupted(self, tx: Transmission[P]) -> Transmission[P]:
        """A copy of ``tx`` for one receiver, with bytes that differ from the ones sent."""
        rng = self.rng
        data = bytearray(tx.data)
        if not data:
            data.append(rng.randrange(256))
        elif len(data) > 1 and rng.random() < 0.25:
            # Truncation: the receiver got only the start of the frame.
            del data[rng.randrange(1, len(data)) :]
        else:
            for _ in range(1 + rng.randrange(3)):
                # XOR with a non-zero byte always changes the byte.
                data[rng.randrange(len(data))] ^= 1 + rng.randrange(255)
            if data == tx.data:
                # Two flips of the same byte can cancel out; guarantee damaged bytes.
                data[0] ^= 0xFF
        return Transmission(
            tx.src,
            tx.dst,
            tx.kind,
            bytes(data),
            tx._decoder,
            corrupted=True,
            epoch=tx._epoch,
            end=tx._end,
        )

    # --- delivering ---------------------------------------------------------------------

    def _deliver_chain(
        self, tx: Transmission[P], times: list[float], dsts: list[int], start: int
    ) -> None:
        """Scheduler event: deliver ``tx`` to the receivers due now, then wait for the next."""
        t = times[start]
        end = start + 1
        n = len(times)
        while end < n and times[end] == t:
            end += 1
        if end < n:
            # Scheduled before delivering, so a callback that raises cannot break the chain.
            self._sched.call_at(times[end], self._deliver_chain, tx, times, dsts, end)
        self._deliver(tx, dsts[start:end])

    def _deliver(self, tx: Transmission[P], receivers: Iterable[int]) -> None:
        """Scheduler event: hand ``tx`` to each receiver still attached and connected."""
        now = self._sched.now
        src = tx.src
        handlers = self._handlers
        drops = self.drops
        if self._epochs.get(src) != tx._epoch or src not in handlers:
            # The sender has detached since sending: was the packet already on the air?
            left = self._left.get((src, tx._epoch))
            if left is not None and left < tx._end:
                drops["detached"] += sum(1 for dst in receivers if dst != src)
                return
        group = self._group
        src_group = group.get(src, _REST) if group else _REST
        size = len(tx.data)
        kind = tx.kind
        traffic = self.traffic
        rows = traffic._rows
        kind_rows = traffic._kind_rows(kind)
        for dst in receivers:
            if dst == src:
                continue
            handler = handlers.get(dst)
            if handler is None:
                drops["detached"] += 1
                continue
            if group and group.get(dst, _REST) != src_group:
                drops["partition"] += 1
                continue
            # Traffic.count_received, inlined: this loop runs once per packet received.
            row = rows.get(dst)
            if row is None:
                row = rows[dst] = [0, 0, 0, 0]
            row[2] += 1
            row[3] += size
            row = kind_rows.get(dst)
            if row is None:
                row = kind_rows[dst] = [0, 0, 0, 0]
            row[2] += 1
            row[3] += size
            handler(tx, now)
