"""The Eclipse Zenoh transport: peer-to-peer, over Wi-Fi or any IP network.

Theory of operation
-------------------
Every platform opens one Zenoh session in *peer* mode and uses two key expressions under
its swarm's namespace ``actorswarm/<swarm>/``:

* ``all/<sender>`` — broadcasts (heartbeats, barrier releases, swarm events). Every
  platform subscribes to ``all/*`` and drops its own (the sender is in the key, so no
  payload has to be decoded to tell).
* ``to/<dst>`` — unicasts (reliable control traffic to one platform). A platform subscribes
  to its own ``to/<id>`` only.

Everything is put **best effort** with congestion control *drop*: the collective core has
its own acknowledgements and retransmissions (as the paper runs Fast DDS in its unreliable
mode), and a packet Zenoh would queue behind a slow link is worth less than the next
heartbeat. Ground-station traffic (``urgent``) goes at Zenoh's ``INTERACTIVE_HIGH``
priority, the rest at ``DATA``, so an operator's command overtakes swarm chatter in every
queue.

Discovery: multicast scouting is on by default (peers find each other on the LAN); list
``connect`` endpoints (``tcp/10.0.0.1:7447``) or a router where Wi-Fi drops multicast, and
``listen`` endpoints to accept them. Zenoh's own session lease is shortened (1 s, four
keep-alives per lease) so a dead peer's session is torn down quickly and Zenoh does not
keep buffering for it; failure detection itself stays the core's (heartbeats, 500 ms).

Memory: Zenoh's buffers are sized for a small robot (:data:`SMALL_ROBOT`, the figures in
``docs/deploying.md``): no shared-memory transport, 8 KiB batches instead of 64 KiB, and a
1 MiB cap on a reassembled message.

Threads: Zenoh calls the receive callback on its own threads. The callback given here must
be thread-safe; the daemon's passes the bytes to its asyncio loop with
``call_soon_threadsafe`` and nothing else.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from types import TracebackType
from typing import Any

import zenoh

__all__ = ["SMALL_ROBOT", "ZenohSettings", "ZenohTransport", "key_prefix"]

log = logging.getLogger("actorswarm.transport")

#: Zenoh configuration for a robot's one daemon (``ZenohSettings.extra`` overrides any).
#:
#: * ``shared_memory``: off. It only helps processes on one host, and Zenoh maps a 16 MiB
#:   pool per process as soon as a message over 3 KiB goes to a local peer: 30 Zenoh
#:   peers on one host putting a 16 KB message every 5 s reached 622 MiB RSS each with it,
#:   34 MiB without it.
#: * ``batch_size`` and ``rx/buffer_size``: 8 KiB. A link's transmit queues hold two batches
#:   per priority in use (this transport uses two, Zenoh its control one) and its receiver
#:   a pool of batch-sized buffers, so their memory scales with the batch size times the
#:   number of peers. Heartbeats and the core's control packets are a few hundred bytes; a
#:   larger packet (a 16 KB deploy chunk) is fragmented by Zenoh and reassembled, also
#:   to and from a peer left at Zenoh's 64 KiB default (tested).
#: * ``rx/max_message_size``: 1 MiB instead of 1 GiB: the most a peer can make this process
#:   hold for one fragmented message (Zenoh sits below the packet guard: the peer need not
#:   be authenticated). The core refuses packets over ``max_packet_bytes`` (60 000 by
#:   default) anyway.
#:
#: Zenoh's queue lengths stay at its default (two batches per priority, allocated when a
#: priority is first used): shorter queues would drop a burst of packets to a busy peer.
SMALL_ROBOT: dict[str, Any] = {
    "transport/shared_memory/enabled": False,
    "transport/link/tx/batch_size": 8192,
    "transport/link/rx/buffer_size": 8192,
    "transport/link/rx/max_message_size": 1 << 20,
}


def key_prefix(swarm: str) -> str:
    """The key-expression namespace of a swarm: ``actorswarm/<swarm>``. ValueError for a
    name Zenoh could not carry in one chunk (``/``, ``*``, ``$``, ``?``, ``#``, empty)."""
    if not swarm or any(c in swarm for c in "/*$?# "):
        raise ValueError(
            f"swarm name {swarm!r}: use letters, digits, '-', '_' or '.' (no '/', '*', '$', "
            "'?', '#' or spaces)"
        )
    return f"actorswarm/{swarm}"


@dataclass(frozen=True, slots=True)
class ZenohSettings:
    """How to reach the other platforms.

    ``listen`` and ``connect`` are Zenoh endpoints (``tcp/127.0.0.1:7501``,
    ``udp/0.0.0.0:7447``); ``multicast`` turns multicast scouting on (the default: peers on
    the same LAN find each other); ``lease_ms`` is Zenoh's session lease (a peer silent that
    long is dropped by Zenoh itself).
    """

    listen: Sequence[str] = ()
    connect: Sequence[str] = ()
    multicast: bool = True
    lease_ms: int = 1000
    extra: dict[str, Any] = field(default_factory=dict)

    def config(self) -> zenoh.Config:
        """The Zenoh configuration these settings stand for."""
        cfg = zenoh.Config()
        cfg.insert_json5("mode", json.dumps("peer"))
        if self.listen:
            # Without endpoints Zenoh's default stays: a peer listens on an ephemeral TCP
            # port of every interface, which multicast scouting then advertises. An empty
            # list would leave the platform unreachable by the peers that scout it.
            cfg.insert_json5("listen/endpoints", json.dumps(list(self.listen)))
        cfg.insert_json5("connect/endpoints", json.dumps(list(self.connect)))
        cfg.insert_json5("scouting/multicast/enabled", json.dumps(self.multicast))
        cfg.insert_json5("transport/link/tx/lease", json.dumps(self.lease_ms))
        cfg.insert_json5("transport/link/tx/keep_alive", json.dumps(4))
        for key, value in {**SMALL_ROBOT, **self.extra}.items():
            cfg.insert_json5(key, json.dumps(value))
        return cfg


class ZenohTransport:
    """Platform ``platform`` of swarm ``swarm`` on Zenoh; ``on_receive(data)`` gets every
    packet addressed to it or broadcast by another platform (on a Zenoh thread).

    Opening fails with :class:`zenoh.ZError` (an endpoint that cannot be bound, a bad
    locator); sending after :meth:`close` is ignored.
    """

    def __init__(
        self,
        swarm: str,
        platform: int,
        on_receive: Callable[[bytes], None],
        settings: ZenohSettings | None = None,
    ) -> None:
        self.swarm = swarm
        self.platform = platform
        self.settings = settings or ZenohSettings()
        self._prefix = key_prefix(swarm)
        self._on_receive = on_receive
        self._me = str(platform)
        self.sent = 0
        self.received = 0
        self._session: zenoh.Session | None = zenoh.open(self.settings.config())
        self._subscribers = [
            self._session.declare_subscriber(f"{self._prefix}/all/*", self._broadcast_in),
            self._session.declare_subscriber(f"{self._prefix}/to/{platform}", self._unicast_in),
        ]
        # One publisher per destination and priority, declared on first use ("all" for
        # broadcasts): a declared publisher is cheaper per put than a bare session.put.
        self._publishers: dict[tuple[str, bool], zenoh.Publisher] = {}

    def __repr__(self) -> str:
        state = "closed" if self._session is None else "open"
        return f"ZenohTransport(swarm={self.swarm!r}, platform={self.platform}, {state})"

    def __enter__(self) -> ZenohTransport:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

    # --- receiving (Zenoh threads) ----------------------------------------------------------

    def _broadcast_in(self, sample: zenoh.Sample) -> None:
        if str(sample.key_expr).rsplit("/", 1)[-1] == self._me:
            return  # our own broadcast
        self._deliver(sample)

    def _unicast_in(self, sample: zenoh.Sample) -> None:
        self._deliver(sample)

    def _deliver(self, sample: zenoh.Sample) -> None:
        self.received += 1
        self._on_receive(sample.payload.to_bytes())

    # --- sending ----------------------------------------------------------------------------

    def send(self, dst: int | None, data: bytes, *, urgent: bool = False, kind: str = "") -> None:
        """Broadcast ``data`` (``dst`` None) or send it to platform ``dst``; ``urgent`` for
        the ground station's traffic (higher priority); ``kind`` is not used (Zenoh keeps no
        statistics per packet type). Never blocks on a slow peer."""
        session = self._session
        if session is None:
            return
        self.sent += 1
        key = f"all/{self._me}" if dst is None else f"to/{dst}"
        publisher = self._publishers.get((key, urgent))
        if publisher is None:
            publisher = self._publishers[(key, urgent)] = session.declare_publisher(
                f"{self._prefix}/{key}",
                priority=zenoh.Priority.INTERACTIVE_HIGH if urgent else zenoh.Priority.DATA,
                congestion_control=zenoh.CongestionControl.DROP,
                reliability=zenoh.Reliability.BEST_EFFORT,
            )
        publisher.put(data)

    def close(self) -> None:
        """Leave the swarm's network (idempotent)."""
        session, self._session = self._session, None
        if session is None:
            return
        for sub in self._subscribers:
            sub.undeclare()  # type: ignore[no-untyped-call]
        for pub in self._publishers.values():
            pub.undeclare()  # type: ignore[no-untyped-call]
        self._publishers.clear()
        try:
            session.close()  # type: ignore[no-untyped-call]
        except zenoh.ZError as exc:
            # Zenoh gives up closing a session whose link is losing packets ("close
            # operation timed out"). Everything this side had to say was sent before; the
            # peers notice the session gone by its lease. Not worth failing a command for.
            log.warning("zenoh session close: %s", exc)
