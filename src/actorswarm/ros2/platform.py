"""A daemon's ROS 2 node, as its plugins use it: ``ctx.ros2``.

Theory of operation
-------------------
One :class:`PlatformRos` per daemon (``actorswarm daemon --ros2``, or a ``[ros2]`` table in
its configuration), owned by the daemon: its node is ``/<swarm>/p<N>/platform``, so a
relative topic name (``detections``) is ``/<swarm>/p<N>/detections``. Plugins never make
nodes nor spin: they ask the context's ``ros2`` to

* :meth:`~PlatformRos.subscribe` — a :class:`Reader` whose :meth:`Reader.take` returns the
  messages that came since the last call (read it in ``step``). One ROS 2 subscription
  serves every reader of a topic; each reader keeps at most ``keep`` messages, dropping the
  oldest (counted). A reader no longer referenced (its plugin stopped) is forgotten.
* :meth:`~PlatformRos.publish` a message (made with :meth:`~PlatformRos.message`);
* :meth:`~PlatformRos.call` a service: a :class:`~actorswarm.ros2.node.Call` to look at in
  later steps (``done``, ``result``), never waited for.

Messages reach the readers on the daemon's loop (:meth:`PlatformRos.pump`, at each wake); a
message that comes wakes the loop, so a plugin's next step sees it. What goes wrong — a
topic of another type, a message that does not decode, a plugin's filter on a field that is
not there — is reported (:meth:`PlatformRos.drain_errors`) naming the topic, and the daemon
logs it as ``ros2-error``; nothing of it reaches the swarm's protocol.
"""

from __future__ import annotations

import asyncio
import weakref
from collections import deque
from collections.abc import Callable
from typing import Any

from actorswarm.ros2.load import message_type
from actorswarm.ros2.node import Call, Inlet, RosNode, Waker

__all__ = ["PlatformRos", "Reader"]


class Reader:
    """One plugin's view of a subscribed topic: :meth:`take` the messages that came."""

    def __init__(self, topic: str, keep: int) -> None:
        self.topic = topic
        self._queue: deque[Any] = deque(maxlen=keep)
        #: Messages dropped because this reader did not take them in time.
        self.dropped = 0

    def _put(self, message: Any) -> None:
        if len(self._queue) == self._queue.maxlen:
            self.dropped += 1
        self._queue.append(message)

    @property
    def waiting(self) -> bool:
        """True when messages wait to be taken."""
        return bool(self._queue)

    def take(self) -> list[Any]:
        """The messages that came since the last call, oldest first."""
        out = list(self._queue)
        self._queue.clear()
        return out


class PlatformRos:
    """The ROS 2 node of platform ``platform`` of swarm ``swarm`` (see the module
    docstring). :meth:`start` after the daemon's loop is running; :meth:`close` at its
    stop."""

    def __init__(
        self,
        platform: int,
        swarm: str,
        loop: asyncio.AbstractEventLoop,
        *,
        domain: int | None = None,
    ) -> None:
        """The node of ``platform``, waking ``loop`` when messages come (``domain`` None:
        ``ROS_DOMAIN_ID``); :class:`~actorswarm.ros2.load.Ros2Error` (or
        ``Ros2Unavailable``) when it cannot be made."""
        self.platform = platform
        self.swarm = swarm
        self.namespace = f"/{swarm}/p{platform}"
        self._topics: dict[tuple[str, str, str], tuple[Inlet, weakref.WeakSet[Reader]]] = {}
        self._reports: list[str] = []
        #: What plugins reported (:meth:`report`) since the node was made.
        self.reported = 0
        self._wake_loop: Callable[[], None] = lambda: None
        waker = Waker(loop, self._woken)
        self.node = RosNode("platform", self.namespace, wake=waker, domain_id=domain)

    def _woken(self) -> None:
        self._wake_loop()

    def on_wake(self, callback: Callable[[], None]) -> None:
        """Call ``callback()`` on the loop when ROS 2 brought something (the daemon's
        ``inbox.poke``)."""
        self._wake_loop = callback

    def start(self) -> None:
        self.node.start()

    def close(self) -> None:
        self.node.close()

    # --- for plugins ----------------------------------------------------------------------

    def subscribe(
        self, topic: str, type_name: str, *, qos: str = "reliable", keep: int = 100
    ) -> Reader:
        """A :class:`Reader` of ``topic`` (type ``type_name``, e.g.
        ``vision_msgs/msg/Detection2DArray``); :class:`~actorswarm.ros2.load.Ros2Error`
        naming the topic when the type is not installed or the name is not valid."""
        key = (topic, type_name, qos)
        entry = self._topics.get(key)
        if entry is None:
            inlet = self.node.subscribe(topic, type_name, qos=qos, keep=max(keep, 100))
            entry = self._topics[key] = (inlet, weakref.WeakSet())
        reader = Reader(entry[0].topic, keep)
        entry[1].add(reader)
        return reader

    def publish(self, topic: str, type_name: str, message: Any, *, qos: str = "reliable") -> None:
        """Publish ``message`` on ``topic``."""
        self.node.publish(topic, type_name, message, qos=qos)

    def call(self, service: str, type_name: str, request: Any, *, timeout: float = 5.0) -> Call:
        """Call ``service``; look at the returned call in later steps."""
        return self.node.call(service, type_name, request, timeout=timeout)

    def message(self, type_name: str) -> Any:
        """The class of message ``type_name`` (``std_msgs/msg/String``), to make one."""
        return message_type(type_name)

    def stamp(self) -> Any:
        """The node's clock now, for a header."""
        return self.node.now_msg()

    def report(self, text: str) -> None:
        """Say what went wrong (the daemon logs it as ``ros2-error``)."""
        self._reports.append(text)
        self.reported += 1

    # --- for the daemon -----------------------------------------------------------------

    def pump(self) -> None:
        """(Loop thread, each wake.) Hand the messages that came to the readers."""
        for inlet, readers in list(self._topics.values()):
            messages = inlet.take()
            if messages:
                for reader in list(readers):
                    for message in messages:
                        reader._put(message)

    def drain_errors(self) -> list[str]:
        out, self._reports = self._reports + self.node.drain_errors(), []
        return out

    def counters(self) -> dict[str, dict[str, int]]:
        """Per topic the node subscribes (the plugins' and the vehicle's): the node's queue
        size ``keep`` (1: only the newest message matters, as for the vehicle's pose, and
        the rest is dropped by design), messages ``received``, ``dropped`` by that queue (a
        flood faster than the loop), ``undecodable``, and ``readers_dropped``: those the
        plugins' readers dropped because they did not take them in time (the readers alive
        now). Counted since the node was made; two subscriptions of one topic add up (their
        largest ``keep``)."""
        readers = {id(inlet): group for inlet, group in self._topics.values()}
        out: dict[str, dict[str, int]] = {}
        for inlet in self.node.inlets:
            counts = inlet.counters()
            counts["readers_dropped"] = sum(r.dropped for r in readers.get(id(inlet), ()))
            before = out.get(inlet.topic)
            if before is not None:
                counts = {k: max(v, before[k]) if k == "keep" else v + before[k]
                          for k, v in counts.items()}  # fmt: skip
            out[inlet.topic] = counts
        return out

    def status(self) -> dict[str, Any]:
        """What the daemon's ``status.json`` says of its ROS 2 node (key ``ros2``): its
        name, whether it still spins, the errors reported since it was made (the log's
        ``ros2-error`` lines, the node's and the plugins') and :meth:`counters`."""
        return {
            "node": self.node.name,
            "alive": self.node.alive,
            "errors": self.node.errors + self.reported,
            "topics": self.counters(),
        }
