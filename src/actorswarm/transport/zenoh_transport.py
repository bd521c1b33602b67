"""The Eclipse Zenoh transport: peer-to-peer, over Wi-Fi or any IP network.

Theory of operation
-------------------
Every platform opens one Zenoh session in *peer* mode and uses two key expressions under
its swarm's namespace ``actorswarm/<swarm>/``:

* ``all/<sender>`` — broadcasts (heartbeats, barrier releases, swarm events). Every
  platform subscribes to ``all/*`` for the other sessions' samples only: Zenoh itself
  leaves its own broadcasts out, no sample is looked at to tell.
* ``to/<dst>`` — unicasts (reliable control traffic to one platform, every command of the
  ground station). A platform subscribes to its own ``to/<id>`` only.
* ``beat/<dst>`` — routine heartbeats sent to one platform: in the star membership, every
  member's heartbeat to its master. A platform subscribes to its own ``beat/<id>``; that
  channel wakes the loop lazily (below). A heartbeat that probes a suspect or answers a
  probe (kind ``"Probe"``) goes on ``to/<dst>``: the probe window is 60 ms.

Everything is put **best effort** with congestion control *drop*: the collective core has
its own acknowledgements and retransmissions (as the paper runs Fast DDS in its unreliable
mode), and a packet Zenoh would queue behind a slow link is worth less than the next
heartbeat. Ground-station traffic (``urgent``) goes at Zenoh's ``INTERACTIVE_HIGH``
priority, the rest at ``DATA``, so an operator's command overtakes swarm chatter in every
queue.

Discovery: multicast scouting is on by default (peers find each other on the LAN); list
``connect`` endpoints (``tcp/10.0.0.1:7447``) or a router where Wi-Fi drops multicast, and
``listen`` endpoints to accept them.

On the air (``broadcast``): with ``"mesh"`` (this class's default; the command line's
when endpoints, scouting or relaying are given) every pair of peers holds one Zenoh
session, over TCP (or UDP unicast) endpoints, so a broadcast leaves its sender as one copy
per peer: N − 1 packets for N platforms. With ``"multicast"`` (the command line's default
otherwise, :attr:`ZenohSettings.fallback`) every platform instead joins
Zenoh's UDP multicast transport on one group (``group``, ``224.0.0.225:7448`` by default,
on ``interface`` when given), and a broadcast is one datagram that every member receives,
as a radio works. Zenoh (1.x) then opens no unicast session to a peer it already meets on
the group, so unicasts travel on the group too: one datagram each, which the other members
receive and drop by key expression. A multicast swarm therefore has no ``listen`` or
``connect`` endpoints and no scouting (:class:`ZenohSettings` refuses them): with a unicast
session beside the group, Zenoh forwards what it receives on one to the other and packets
loop (measured: thousands of packets per second between three idle peers). The ground
station joins the group like any platform.

On a group, no two members declare the same key expression. Zenoh (1.10) can send the
subscriber declarations it receives from a group back to it, and members that share a key
expression then repeat them to each other without end (Zenoh's issue #1608 and pull request
#2802): with every member subscribed to ``all/*``, four bare sessions, one per process, put
3 500 packets a second on an idle group every time, and three daemons up to 12 000 some of
the time; with a pattern of each member's own, no run did (four and ten bare sessions, four
and ten daemons). So on a group every key carries a tail of :data:`SPREAD_CHUNKS`
chunks ``mmmm`` (``all/<sender>/mmmm/mmmm/mmmm/mmmm/mmmm``, ``to/<dst>/mmmm/...``), and each
member subscribes with a pattern of its own that matches that tail: in each chunk a ``$*``
somewhere among the four letters (``m$*m``, ``$*mm``, ``*``...), 15 ways per chunk, chosen
by :func:`spread_pattern` from the platform's ID (the ground station, ID 0, draws one at
random per session, so that two ``gs`` commands at once differ too).

Multicast is UDP: no retransmission below the core (which retransmits what must arrive),
and a datagram larger than the link's MTU is lost whole when one of its IP fragments is.

Multi-hop (``relay``): where platforms reach only their neighbours (a chain or a grid of
radio ranges), each daemon opens its session in Zenoh's *router* mode instead of *peer*.
Routers keep a link-state picture of who is connected to whom and forward every sample
along the shortest path to the routers whose sessions subscribed to it, so a platform's
broadcast or unicast reaches the far end of the chain through the platforms between,
without any part of the collective core knowing. Each relay holds sessions only with the
neighbours it connects to or that connect to it (``connect``/``listen``, or multicast
scouting, which on a radio only its neighbours hear: relays connect to the routers and
peers they scout). A ground station connects as a plain peer to any one relay. A relay
without ``listen`` endpoints listens where Zenoh's routers do, ``tcp/[::]:7447``. Zenoh
(1.10) routes between routers only: a peer's session never forwards, which is why relaying
is a mode of its own. A relay reroutes around a lost link once that link's session
expires, so its lease defaults to :data:`RELAY_LEASE_MS` (3 s) and its receive threads are
kept apart from the one worker (:data:`RELAY_RUNTIME`). The multicast group cannot be
relayed (a link-local group does not cross a hop, and a unicast session beside the group
loops): ``relay`` refuses it. Routers stamp samples with a hybrid clock by default; the
daemon has no use for it, so it is off.

The session lease (:data:`LEASE_MS`, 30 s, with :data:`KEEP_ALIVES` keep-alives per
lease: one every 7.5 s on each idle link, each way) is Zenoh's own failure detection; the
core detects failures itself (heartbeats, ``t_leave`` 0.5 s) and does not wait for it. What
the lease bounds is how long Zenoh keeps a silent peer's session (one whose process died
with its connections still open: a robot that lost power, or one out of radio range):
until it expires, every packet for that peer goes to its TCP connection and, once the
socket's buffer and the session's transmit queue (two batches per priority) are full, is
dropped after waiting up to 1 ms (congestion control *drop*). A process that dies on a
running host closes its connections, and its peers drop its session at once, whatever the
lease. In a star membership most links of the mesh carry nothing but these keep-alives:
at a 1 s lease, four a second each way on each of the N(N − 1)/2 links; at 30 daemons on
one host the 8 s lease's keep-alives were a third of what was on the wire and about
0.15 % of a core of each member's (``docs/benchmarks/README.md``). On the
multicast transport the lease works the same way per member, and each member sends a
*join* on the group every :data:`JOIN_MS` (250 ms; lease / :data:`KEEP_ALIVES` if that is
shorter). A member drops what it receives from a peer whose join it has not heard yet, so
the join interval is how long a newcomer waits before it is heard: a ``gs`` command, a new
process each time, listens 1.5 s for the swarm, and at Zenoh's default (2.5 s, longer than
a short lease too, so members would expire between joins) it would hear nobody; at one
second it heard the master after up to 1.1 s and its roster up to 0.6 s later. Joins are
one datagram per member, not per pair: 4 a second each.

Memory: Zenoh's buffers are sized for a small robot (:data:`SMALL_ROBOT`, the figures in
``docs/deploying.md``): no shared-memory transport, 8 KiB batches instead of 64 KiB, and a
1 MiB cap on a reassembled message.

Threads: Zenoh runs its five thread pools (transmit, receive, accept, network, application;
six threads by default) on one thread (:data:`SMALL_ROBOT_RUNTIME`, set in ``ZENOH_RUNTIME``
before the first session opens unless the environment already sets it). A daemon's traffic
is a few hundred small packets a second, and every thread handing a packet to another is a
context switch (docs/benchmarks/README.md, "One Zenoh thread and no receiving threads":
with 30 daemons on a 2-core host, the master's CPU fell from 3.6–4.0 % of a core to 3.3 %).

Receiving: packets wait in bounded channels of :data:`RX_CAPACITY` until the host's loop
takes them in batches with :meth:`ZenohTransport.drain`, the unicast channel (``to/<id>``,
which carries every ground-station command) first. A burst beyond a channel's capacity
overwrites its *oldest* packets: Zenoh's thread never waits for a busy loop (a blocked
receive thread would stall the whole link, keep-alives included), and the newest heartbeat
is worth more than an old one; the core retransmits what must arrive. A drain that finds a
channel full counts one in ``ring_full`` (packets were probably lost).

Wake-ups (:meth:`ZenohTransport.watch`): the unicast and broadcast channels are filled by a
callback that Zenoh runs on its own thread, and that does as little as Python can: it
appends the packet's bytes to the channel's queue and, for the first packet after a drain
emptied the channel, calls ``wake()`` — once per burst, however many packets follow
before the loop runs. The callback runs on Zenoh's thread (``indirect=False``), which
keeps a Python thread state for good from its first callback on (without, each callback
made and tore down one: a ``gettid``, a 16 KiB stack mapped and unmapped, ten times a
second on an idle member). No Python thread waits in a channel's ``recv()``: that costs
context switches on every burst, and zenoh-python's blocking ``recv()`` wakes every 100 ms
to look for signals (an idle member's three such threads took 0.35 % of its 1.1 % of a
core). A drain marks the channel quiet *before* it takes, so a packet
that arrives while it takes wakes the loop again rather than wait unseen. The daemon's
``wake`` is :meth:`actorswarm.daemon.loop.Inbox.notify`, which schedules at most one wake
of the asyncio loop however many channels ask before it runs.

The heartbeat channel (``beat/<id>``) runs no Python per packet at all: it is a
:class:`zenoh.handlers.RingChannel` that Zenoh fills and that nobody watches; every drain
empties it, and the loop never sleeps longer than ``beat_delay_ms`` (:data:`BEAT_DELAY_MS`,
100 ms, the core's default heartbeat interval; :attr:`ZenohTransport.longest_sleep`). A
star master hears N − 1 members' heartbeats, each on its own: at 30 daemons and 10 Hz that
was 290 wakes of the loop a second, each costing more than the packet it carried. A
platform wakes once per heartbeat interval anyway, to send its own heartbeat, and that wake
takes every member's heartbeat that waits: so its members' heartbeats ride on it, and its
loop wakes about ten times a second whatever N. What it costs is up to one interval more
before a member's silence is noticed (its leave takes ``t_leave`` and its probes anyway); a
heartbeat waiting in the channel is taken before the tick that could suspect its sender, so
a waiting heartbeat never makes its sender look silent. With ``beat_delay_ms`` 0 the
heartbeat channel wakes the loop like the others. The master's own heartbeats, which every
member's failure detection of the master hangs on, travel on ``all/<sender>`` and wake the
loop at once, as do probes and their answers.
"""

from __future__ import annotations

import dataclasses
import ipaddress
import json
import logging
import os
import random
import re
import threading
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from types import TracebackType
from typing import Any

import zenoh

__all__ = [
    "BEAT_DELAY_MS",
    "BROADCASTS",
    "CLOSE_WAIT_S",
    "DEFAULT_GROUP",
    "JOIN_MS",
    "KEEP_ALIVES",
    "LEASE_MS",
    "RELAY_LEASE_MS",
    "RELAY_RUNTIME",
    "RX_CAPACITY",
    "SMALL_ROBOT",
    "SMALL_ROBOT_RUNTIME",
    "SPREAD_CHUNKS",
    "SPREAD_PATTERNS",
    "ZenohSettings",
    "ZenohTransport",
    "check_group",
    "check_interface",
    "closing",
    "key_prefix",
    "spread_pattern",
    "use_small_robot_runtime",
]

log = logging.getLogger("actorswarm.transport")


def _in_words(exc: BaseException) -> str:
    """Zenoh's error message without the Rust source location it ends each part with."""
    return re.sub(r" at \S+\.rs:\d+\.?\]?", "", " ".join(str(exc).split()))


#: How long a command's or a daemon's end waits for Zenoh's close, seconds: done in
#: milliseconds on a clean link; over a lossy one the rest goes on (:func:`closing`).
CLOSE_WAIT_S = 0.5

#: Closes left running by :meth:`ZenohTransport.close` (``wait``): threads that the
#: interpreter waits for at its exit, unless the process leaves at once (:func:`closing`).
_closes: list[threading.Thread] = []


def closing() -> bool:
    """Whether a Zenoh session is still closing on a thread of its own. A command that
    has said everything may then leave with ``os._exit``: the kernel closes the links and
    still sends what they hold, and the peers see the session end. (Exiting through the
    interpreter's shutdown instead, with the close's thread cut off, aborts the process.)"""
    _closes[:] = [t for t in _closes if t.is_alive()]
    return bool(_closes)


def _close(session: zenoh.Session) -> None:
    """Close ``session``; a close Zenoh gives up is logged, never raised."""
    try:
        session.close()  # type: ignore[no-untyped-call]
    except zenoh.ZError as exc:
        # "close operation timed out" over a lossy link: everything this side had to say
        # was sent before, and the peers drop the session by its lease at worst. Not worth
        # failing a command for.
        log.warning(
            "zenoh session close: %s (a lossy link; the peers drop the session by its lease)",
            _in_words(exc),
        )


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

#: Zenoh's thread pools for a robot's daemon (``ZENOH_RUNTIME``, read by Zenoh once per
#: process when it starts its first session): the application pool with one worker, and
#: every other pool handed over to it (see the module's docstring). An environment that
#: sets ``ZENOH_RUNTIME`` itself keeps its own.
SMALL_ROBOT_RUNTIME = (
    "(app: (worker_threads: 1), acc: (handover: app), tx: (handover: app), "
    "rx: (handover: app), net: (handover: app))"
)


#: A relay's thread pools (``relay``): :data:`SMALL_ROBOT_RUNTIME` but for the receive pool,
#: kept apart. Handed over to the one application worker, the receive task of a link whose
#: radio went silent held it, and a relay rerouted around the lost link only some 13 s
#: later, or not within 40 s, instead of within Zenoh's lease (three relays in a triangle,
#: one link cut: ``scripts/relay_flap.py``).
RELAY_RUNTIME = (
    "(app: (worker_threads: 1), acc: (handover: app), tx: (handover: app), net: (handover: app))"
)


def use_small_robot_runtime(*, relay: bool = False) -> str:
    """Ask for :data:`SMALL_ROBOT_RUNTIME` (:data:`RELAY_RUNTIME` for a relay) unless
    ``ZENOH_RUNTIME`` is set already; returns what the environment holds. Too late once
    this process opened a Zenoh session."""
    return os.environ.setdefault("ZENOH_RUNTIME", RELAY_RUNTIME if relay else SMALL_ROBOT_RUNTIME)


#: Samples each receive channel (unicasts, broadcasts) holds before the oldest is
#: overwritten. 30 peers heartbeating at 10 Hz fill the broadcast channel in about 0.4 s of
#: a loop that does not drain it; packets are a few hundred bytes, so a full channel holds
#: some 40 KiB (a ring of 16 KB deploy chunks, 2 MiB). The daemon's loop takes up to 256
#: packets per wake (:data:`actorswarm.daemon.loop.BATCH_LIMIT`): both channels at once.
RX_CAPACITY = 128


#: How broadcasts travel (see the module's docstring): one session per pair of peers, or
#: Zenoh's UDP multicast transport.
BROADCASTS = ("mesh", "multicast")

#: The multicast group of ``broadcast="multicast"`` unless one is given: link-local (routers
#: do not forward it), next to Zenoh's scouting group (224.0.0.224:7446).
DEFAULT_GROUP = "224.0.0.225:7448"

#: Zenoh's session lease, milliseconds (see the module's docstring).
LEASE_MS = 30_000

#: A relay's lease unless one is given, milliseconds: a relay reroutes around a lost link
#: only once that link's session expired, so its lease is how long the platforms behind it
#: stay cut off (three relays in a triangle, one link cut: the swarm whole again 3 s after
#: the cut at 3 s, ``scripts/relay_flap.py``). A relay holds a session with its neighbours
#: only: four keep-alives per lease on a few links.
RELAY_LEASE_MS = 3_000

#: Chunks of the tail that keys carry on a multicast group (see the module's docstring).
SPREAD_CHUNKS = 5
_SPREAD = "/".join(["mmmm"] * SPREAD_CHUNKS)
#: Each chunk of a pattern: "m" * a + "$*" + "m" * c with a + c <= 4, which matches "mmmm".
_CHUNK_PATTERNS = tuple(
    "*" if a + c == 0 else "m" * a + "$*" + "m" * c for a in range(5) for c in range(5 - a)
)
#: Distinct patterns: 15 ** 5 = 759 375, platform IDs are 1..65535.
SPREAD_PATTERNS = len(_CHUNK_PATTERNS) ** SPREAD_CHUNKS


def spread_pattern(index: int) -> str:
    """The ``index``-th key-expression tail (0 <= index < :data:`SPREAD_PATTERNS`) that
    matches the ``mmmm/...`` tail of every key on a multicast group; distinct indices give
    distinct strings."""
    if not 0 <= index < SPREAD_PATTERNS:
        raise ValueError(f"spread pattern {index}: 0..{SPREAD_PATTERNS - 1}")
    chunks = []
    for _ in range(SPREAD_CHUNKS):
        index, digit = divmod(index, len(_CHUNK_PATTERNS))
        chunks.append(_CHUNK_PATTERNS[digit])
    return "/".join(chunks)


#: How long the heartbeat channel's thread waits before it wakes the loop, milliseconds:
#: one heartbeat interval of the core's default, so that members' heartbeats ride on the
#: wake their master makes anyway (see the module's docstring).
BEAT_DELAY_MS = 100

#: Keep-alives per lease on an idle link.
KEEP_ALIVES = 4

#: The multicast transport's join interval, milliseconds (at most lease / KEEP_ALIVES).
JOIN_MS = 250


def check_group(group: str) -> str:
    """``group`` (``ADDRESS:PORT``, an IPv4 multicast address or a bracketed IPv6 one) as
    Zenoh writes it; ValueError naming what is wrong."""
    host, colon, port = group.rpartition(":")
    bare = host[1:-1] if host.startswith("[") and host.endswith("]") else host
    try:
        address = ipaddress.ip_address(bare)
    except ValueError:
        address = None
    if not colon or address is None or not (port.isascii() and port.isdigit()):
        raise ValueError(
            f"multicast group {group!r}: write ADDRESS:PORT (224.0.0.225:7448, [ff02::1]:7448)"
        )
    if not address.is_multicast:
        raise ValueError(
            f"multicast group {group!r}: {bare} is not a multicast address "
            "(IPv4 224.0.0.0 to 239.255.255.255, IPv6 ff00::/8)"
        )
    if not 1 <= int(port) <= 65535:
        raise ValueError(f"multicast group {group!r}: port {port} is not in 1..65535")
    if address.version == 6 and not host.startswith("["):
        raise ValueError(f"multicast group {group!r}: write an IPv6 address in brackets")
    return f"{host}:{int(port)}"


def check_interface(interface: str) -> str:
    """``interface`` if it can be a network interface's name (``eth0``, ``wlan0``);
    ValueError otherwise. Whether the host has it is for Zenoh to say when it opens."""
    if (
        not interface
        or len(interface) > 15
        or not all(c.isascii() and (c.isalnum() or c in "-_.@") for c in interface)
    ):
        raise ValueError(
            f"interface {interface!r}: a network interface's name, at most 15 letters, "
            "digits, '-', '_', '.' or '@' (eth0, wlan0)"
        )
    return interface


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
    long is dropped by Zenoh itself). ``broadcast`` is how broadcasts travel, ``"mesh"`` or
    ``"multicast"`` (:data:`BROADCASTS`); with ``"multicast"``, every packet travels on
    ``group`` (``ADDRESS:PORT``) through ``interface`` (the system's choice when None), and
    ``listen``, ``connect`` and scouting are refused (see the module's docstring).
    ``beat_delay_ms`` is how long a heartbeat sent to this platform may wait for the loop
    (0: it wakes the loop at once, as every other packet does). ``relay``: this platform
    forwards for the others (Zenoh's router mode, link-state routing: see the module's
    docstring), for a swarm that spans more than one radio hop; not with ``"multicast"``.
    ``fallback``: the group was chosen by default, not asked for: where it cannot be opened
    (no interface of this host carries multicast), :class:`ZenohTransport` opens
    :meth:`as_mesh` instead and says so.

    Construction raises ValueError naming the setting that is wrong.
    """

    listen: Sequence[str] = ()
    connect: Sequence[str] = ()
    multicast: bool = True
    lease_ms: int = LEASE_MS
    extra: dict[str, Any] = field(default_factory=dict)
    broadcast: str = "mesh"
    group: str = DEFAULT_GROUP
    interface: str | None = None
    beat_delay_ms: int = BEAT_DELAY_MS
    relay: bool = False
    fallback: bool = False

    def __post_init__(self) -> None:
        if self.broadcast not in BROADCASTS:
            raise ValueError(
                f"broadcast {self.broadcast!r}: say how broadcasts travel, "
                + " or ".join(BROADCASTS)
            )
        if not 100 <= self.lease_ms <= 3_600_000:
            raise ValueError(f"Zenoh lease {self.lease_ms} ms: give 100 ms to one hour")
        if not 0 <= self.beat_delay_ms <= 100:
            raise ValueError(
                f"heartbeat delay {self.beat_delay_ms} ms: give 0 to 100 ms (a member's "
                "silence is noticed that much later)"
            )
        object.__setattr__(self, "group", check_group(self.group))
        if self.interface is not None:
            check_interface(self.interface)
        if self.broadcast == "multicast":
            extra = [
                what
                for what, given in (
                    ("listen endpoints", self.listen),
                    ("connect endpoints", self.connect),
                    ("multicast scouting", self.multicast),
                    ("relaying", self.relay),
                )
                if given
            ]
            if extra:
                raise ValueError(
                    "broadcast 'multicast' carries everything on the group: no "
                    + ", no ".join(extra)
                    + " (beside the group, a unicast session makes Zenoh forward packets "
                    "between the two, and they loop)"
                )

    def as_mesh(self) -> ZenohSettings:
        """These settings on the mesh instead of the group: multicast scouting."""
        return dataclasses.replace(self, broadcast="mesh", multicast=True, fallback=False)

    @property
    def described(self) -> str:
        """How broadcasts travel, for a log line: ``mesh`` or the group's endpoint."""
        return "mesh" if self.broadcast == "mesh" else self.group_endpoint

    @property
    def group_endpoint(self) -> str:
        """The Zenoh endpoint of the multicast group (``udp/224.0.0.225:7448#iface=wlan0``)."""
        iface = f"#iface={self.interface}" if self.interface else ""
        return f"udp/{self.group}{iface}"

    def config(self) -> zenoh.Config:
        """The Zenoh configuration these settings stand for."""
        cfg = zenoh.Config()
        cfg.insert_json5("mode", json.dumps("router" if self.relay else "peer"))
        if self.relay:
            cfg.insert_json5("timestamping/enabled", json.dumps(False))
            # A router connects to nothing it scouts unless told to: a relay's neighbours
            # are exactly the routers and peers it hears.
            cfg.insert_json5("scouting/multicast/autoconnect", json.dumps(["router", "peer"]))
        if self.broadcast == "multicast":
            cfg.insert_json5("listen/endpoints", json.dumps([self.group_endpoint]))
            cfg.insert_json5(
                "transport/multicast/join_interval",
                json.dumps(min(JOIN_MS, self.lease_ms // KEEP_ALIVES)),
            )
        elif self.listen:
            # Without endpoints Zenoh's default stays: a peer listens on an ephemeral TCP
            # port of every interface, which multicast scouting then advertises. An empty
            # list would leave the platform unreachable by the peers that scout it.
            cfg.insert_json5("listen/endpoints", json.dumps(list(self.listen)))
        cfg.insert_json5("connect/endpoints", json.dumps(list(self.connect)))
        cfg.insert_json5("scouting/multicast/enabled", json.dumps(self.multicast))
        cfg.insert_json5("transport/link/tx/lease", json.dumps(self.lease_ms))
        cfg.insert_json5("transport/link/tx/keep_alive", json.dumps(KEEP_ALIVES))
        for key, value in {**SMALL_ROBOT, **self.extra}.items():
            cfg.insert_json5(key, json.dumps(value))
        return cfg


#: Zenoh's threads that keep a Python thread state for good (:func:`_keep_thread_state`).
_KEPT: set[int] = set()
_get_ident = threading.get_ident


def _keep_thread_state() -> None:
    """Give the calling thread, one of Zenoh's inside a callback, a Python thread state that
    outlives the callback.

    Zenoh calls into Python between ``PyGILState_Ensure`` and ``PyGILState_Release``. On a
    thread Python did not start, that creates a thread state for every callback (a
    ``gettid``, a 16 KiB frame stack mapped) and destroys it after (unmapped again: with the
    loop's thread on the other core, a TLB shoot-down), for every sample. One ``Ensure``
    more that is never released keeps the state, so a callback only takes the GIL. Zenoh's
    threads live as long as the process; a thread state of a thread that never runs Python
    again costs a few hundred bytes."""
    ident = _get_ident()
    _KEPT.add(ident)
    try:
        import ctypes  # imported by the daemon anyway (daemon/heap.py)
    except ImportError:  # an interpreter built without ctypes: every callback pays
        return
    ctypes.pythonapi.PyGILState_Ensure()


class _Channel:
    """One subscriber's packets and how they wake the loop (see the module's docstring):
    a queue that Zenoh's thread appends to through :meth:`on_sample`, or (``ring``) a
    :class:`zenoh.handlers.RingChannel` nobody watches, emptied by every drain."""

    __slots__ = ("announced", "bursts", "capacity", "full", "queue", "ring", "subscriber", "wake")

    def __init__(self, capacity: int, *, ring: bool = False) -> None:
        self.capacity = capacity
        self.queue: deque[bytes] = deque(maxlen=capacity)
        self.ring = ring
        #: Set with the subscriber's declaration.
        self.subscriber: zenoh.Subscriber[Any] | None = None
        #: The loop's wake-up, once :meth:`ZenohTransport.watch` gave it.
        self.wake: Callable[[], None] | None = None
        #: True from the first packet of a burst until a drain takes the channel's packets:
        #: the burst asked for its wake-up.
        self.announced = False
        self.bursts = 0  # wake-ups this channel asked for (written on Zenoh's thread only)
        self.full = 0  # drains that found the channel full (written by the loop only)

    def on_sample(self, sample: zenoh.Sample) -> None:
        """Zenoh's callback, on its thread: keep the packet, wake the loop once per burst.
        (Appending to a full deque drops its oldest: the ring's behaviour.)"""
        if _get_ident() not in _KEPT:
            _keep_thread_state()
        self.queue.append(sample.payload.to_bytes())
        if self.announced:
            return
        self.announced = True
        wake = self.wake
        if wake is not None:
            self.bursts += 1
            wake()

    def take(self, out: list[bytes], limit: int) -> None:
        """Move waiting packets to ``out`` until it holds ``limit`` (on the loop's thread)."""
        if self.ring:
            assert self.subscriber is not None
            try_recv = self.subscriber.handler.try_recv
            taken = 0
            while len(out) < limit:
                sample = try_recv()
                if sample is None:
                    break
                out.append(sample.payload.to_bytes())
                taken += 1
            if taken >= self.capacity:
                self.full += 1
            return
        queue = self.queue
        if len(queue) >= self.capacity:
            self.full += 1
        # Quiet before taking: a packet that arrives meanwhile asks for a wake of its own
        # (at worst one that finds nothing) instead of waiting unseen.
        self.announced = False
        while queue and len(out) < limit:
            out.append(queue.popleft())


class ZenohTransport:
    """Platform ``platform`` of swarm ``swarm`` on Zenoh: every packet addressed to it or
    broadcast by another platform waits in a ring of ``capacity`` samples per channel
    (:data:`RX_CAPACITY`) until :meth:`drain` takes it; :meth:`watch` says when to.

    Opening fails with :class:`zenoh.ZError` (an endpoint that cannot be bound, a bad
    locator); sending or draining after :meth:`close` is ignored.
    """

    def __init__(
        self,
        swarm: str,
        platform: int,
        settings: ZenohSettings | None = None,
        *,
        capacity: int = RX_CAPACITY,
    ) -> None:
        if capacity < 1:
            raise ValueError(f"receive capacity {capacity}: at least one packet per channel")
        self.swarm = swarm
        self.platform = platform
        self.settings = settings or ZenohSettings()
        self._prefix = key_prefix(swarm)
        self._me = str(platform)
        self.sent = 0
        #: Packets :meth:`drain` handed over.
        self.received = 0
        self._wake: Callable[[], None] | None = None
        use_small_robot_runtime(relay=self.settings.relay)
        #: Why the group chosen by default could not be opened (None: it was, or it was not
        #: the default): this transport is on the mesh instead.
        self.fell_back: str | None = None
        try:
            self._session: zenoh.Session | None = zenoh.open(self.settings.config())
        except zenoh.ZError as exc:
            if not self.settings.fallback:
                raise
            self.fell_back = _in_words(exc)
            log.warning(
                "cannot open the multicast group %s (%s): on the mesh instead; every platform "
                "and ground station must then be on it (--broadcast mesh), or give --interface",
                self.settings.group_endpoint,
                self.fell_back,
            )
            self.settings = self.settings.as_mesh()
            self._session = zenoh.open(self.settings.config())
        # On a multicast group every key has a tail, and each member matches it with a
        # pattern of its own (see the module's docstring).
        self._tail, pattern = "", ""
        if self.settings.broadcast == "multicast":
            # Platforms take their ID (1..65535); a ground station a random index above.
            index = platform or random.SystemRandom().randrange(65536, SPREAD_PATTERNS)
            self._tail, pattern = f"/{_SPREAD}", f"/{spread_pattern(index)}"
        # Unicasts first: the ground station only ever sends to one platform (``to/<id>``),
        # so its commands are in the first channel a drain empties.
        delay = self.settings.beat_delay_ms / 1000
        self._channels = (
            _Channel(capacity),
            _Channel(capacity),
            _Channel(capacity, ring=delay > 0),
        )
        #: The longest the host's loop may sleep between two drains (the heartbeat
        #: channel's delay; None when every channel wakes the loop).
        self.longest_sleep: float | None = delay if delay > 0 else None
        keys = (f"to/{platform}", "all/*", f"beat/{platform}")
        for ch, key in zip(self._channels, keys, strict=True):
            handler: Any = (
                zenoh.handlers.RingChannel(capacity)
                if ch.ring
                else zenoh.handlers.Callback(ch.on_sample, indirect=False)
            )
            # Our own broadcasts are left out by Zenoh itself (REMOTE), not looked at.
            origin = zenoh.Locality.REMOTE if key == "all/*" else zenoh.Locality.ANY
            ch.subscriber = self._session.declare_subscriber(
                f"{self._prefix}/{key}{pattern}", handler, allowed_origin=origin
            )
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

    # --- receiving ----------------------------------------------------------------------------

    @property
    def bursts(self) -> int:
        """Wake-ups asked for: one per burst of packets, however many it held."""
        return sum(ch.bursts for ch in self._channels)

    @property
    def ring_full(self) -> int:
        """Drains that found a channel full (its oldest packets were probably overwritten)."""
        return sum(ch.full for ch in self._channels)

    @property
    def waiting(self) -> int:
        """Packets waiting in the unicast and broadcast channels (the heartbeat ring cannot
        be counted without taking from it), for a status report or a test."""
        return sum(len(ch.queue) for ch in self._channels if not ch.ring)

    def receive_counters(self) -> dict[str, int]:
        """``bursts`` and ``ring_full``, for a status report."""
        return {"bursts": self.bursts, "ring_full": self.ring_full}

    def watch(self, wake: Callable[[], None]) -> None:
        """Call ``wake()`` (on Zenoh's thread) whenever packets start waiting after a drain
        took their channel's: once per burst (the heartbeat channel never: see
        :attr:`longest_sleep`). Once per transport; packets that arrived before are
        announced at once."""
        if self._wake is not None:
            raise RuntimeError(f"{self!r} is already watched")
        if self._session is None:
            return
        self._wake = wake
        for ch in self._channels:
            ch.wake = wake
        if any(ch.queue for ch in self._channels):
            wake()

    def drain(self, limit: int) -> list[bytes]:
        """Up to ``limit`` packets that wait, unicasts, then broadcasts, then heartbeats,
        each channel's oldest first (on the loop's thread). Never blocks."""
        out: list[bytes] = []
        if self._session is None:
            return out
        for ch in self._channels:
            if len(out) >= limit:
                break
            ch.take(out, limit)
        self.received += len(out)
        return out

    # --- sending ----------------------------------------------------------------------------

    def send(self, dst: int | None, data: bytes, *, urgent: bool = False, kind: str = "") -> None:
        """Broadcast ``data`` (``dst`` None) or send it to platform ``dst``; ``urgent`` for
        the ground station's traffic (higher priority); ``kind``, the packet's kind
        (:attr:`~actorswarm.core.ready.Outgoing.kind`), sends a ``"Heartbeat"`` to one
        platform on its lazy heartbeat channel. Never blocks
        on a slow peer."""
        session = self._session
        if session is None:
            return
        self.sent += 1
        if dst is None:
            key = f"all/{self._me}"
        else:
            key = f"beat/{dst}" if kind == "Heartbeat" else f"to/{dst}"
        publisher = self._publishers.get((key, urgent))
        if publisher is None:
            publisher = self._publishers[(key, urgent)] = session.declare_publisher(
                f"{self._prefix}/{key}{self._tail}",
                priority=zenoh.Priority.INTERACTIVE_HIGH if urgent else zenoh.Priority.DATA,
                congestion_control=zenoh.CongestionControl.DROP,
                reliability=zenoh.Reliability.BEST_EFFORT,
            )
        publisher.put(data)

    def close(self, *, wait: float | None = None) -> None:
        """Leave the swarm's network (idempotent). ``wait``: close on a thread of its own
        and return after at most ``wait`` seconds (see :func:`closing`); None: return when
        Zenoh's close is done."""
        session, self._session = self._session, None
        if session is None:
            return
        for ch in self._channels:
            ch.wake = None
            if ch.subscriber is not None:
                ch.subscriber.undeclare()  # type: ignore[no-untyped-call]
        for pub in self._publishers.values():
            pub.undeclare()  # type: ignore[no-untyped-call]
        self._publishers.clear()
        # Zenoh's close flushes every link and waits for each peer's goodbye: over a lossy
        # link seconds (a median of 5 s at 20 % loss, scripts/gs_latency.py), and 10 s when
        # it gives up. The thread is not a daemon one: an interpreter that shut down under
        # a close still running aborted ("FATAL: exception not rethrown", 1 command in 15).
        if wait is None:
            _close(session)
            return
        thread = threading.Thread(target=_close, args=(session,), name="zenoh-close")
        _closes.append(thread)
        thread.start()
        thread.join(wait)
