"""One ROS 2 node with its own executor thread, reached from an asyncio loop without
blocking it.

Theory of operation
-------------------
A :class:`RosNode` owns an rclpy context (its own, so several nodes of one process, or a
test, never share a global state), one node and a single-threaded executor spinning in a
daemon thread. Everything ROS 2 calls back — a message, a service request, a graph event —
runs on that thread, so nothing of the swarm ever runs there:

* a subscription (:meth:`RosNode.subscribe`) is an :class:`Inlet`: a bounded queue the
  callback appends to — the oldest message dropped and counted when a publisher floods —
  and a *wake* (``loop.call_soon_threadsafe``, at most one pending however many messages
  come) so the loop takes the messages at its next turn (:meth:`Inlet.take`);
* a service (:meth:`RosNode.serve`) hands each request to the loop with
  ``call_soon_threadsafe`` and answers from the loop's reply, within a deadline;
* a service call (:meth:`RosNode.call`) returns a :class:`Call` at once; the loop looks at
  it later (``done``/``result``), and a service that never answers is an error naming it
  after ``timeout`` seconds.

Messages are taken raw and decoded in the callback, so a message that does not decode is
counted and reported (:meth:`RosNode.drain_errors`) naming its topic, not raised in the
executor. A topic of another type than the one subscribed is reported the same way (rmw's
incompatible-type event), as is an incompatible QoS.

Publishing is done from the loop's thread (rclpy's publish is thread-safe).
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any, Final, Literal

from actorswarm.ros2.load import Ros2Error, load_rclpy, message_type

__all__ = ["QOS", "Call", "Inlet", "RosNode", "Waker"]

#: The QoS names a topic may be given: ``reliable`` (depth 10, volatile), ``sensor``
#: (best effort, depth 5: rclpy's sensor-data profile, what pose estimators publish with),
#: ``latched`` (reliable, transient local, depth 1: a late subscriber gets the last value).
Qos = Literal["reliable", "sensor", "latched"]
QOS: Final[tuple[str, ...]] = ("reliable", "sensor", "latched")

#: Seconds between two looks at the graph for topics of another type.
_GRAPH_EVERY: Final = 2.0
#: Errors kept until drained; older ones are dropped (a node that fails for hours).
_ERRORS_KEPT: Final = 100


def qos_profile(name: str, depth: int = 10) -> Any:
    """The rclpy QoS profile of ``name`` (:data:`QOS`)."""
    from rclpy.qos import (
        DurabilityPolicy,
        HistoryPolicy,
        QoSProfile,
        ReliabilityPolicy,
        qos_profile_sensor_data,
    )

    if name == "sensor":
        return qos_profile_sensor_data
    if name == "latched":
        return QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=1,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
        )
    if name == "reliable":
        return QoSProfile(depth=depth)
    raise Ros2Error(f"QoS {name!r}: the QoS profiles are {', '.join(QOS)}")


class Waker:
    """Wakes an asyncio loop from another thread: ``wake()`` schedules ``callback`` on the
    loop, at most once until it ran (thread-safe)."""

    def __init__(self, loop: asyncio.AbstractEventLoop, callback: Callable[[], None]) -> None:
        self._loop = loop
        self._callback = callback
        self._lock = threading.Lock()
        self._armed = False

    def __call__(self) -> None:
        with self._lock:
            if self._armed:
                return
            self._armed = True
        with contextlib.suppress(RuntimeError):  # the loop closed: nobody to wake
            self._loop.call_soon_threadsafe(self._run)

    def _run(self) -> None:
        with self._lock:
            self._armed = False
        self._callback()


class Inlet:
    """The messages of one subscription, waiting for the loop (see the module docstring).

    ``keep`` messages wait at most; beyond, the oldest is dropped and :attr:`dropped`
    counted. :attr:`received` counts every message, :attr:`undecodable` those that did not
    decode."""

    def __init__(self, topic: str, type_name: str, keep: int, wake: Callable[[], None]) -> None:
        self.topic = topic
        self.type_name = type_name
        self._queue: deque[Any] = deque(maxlen=keep)
        self._lock = threading.Lock()
        self._wake = wake
        self.received = 0
        self.dropped = 0
        self.undecodable = 0
        #: When the last message came (time.monotonic), None before the first.
        self.last: float | None = None

    def put(self, message: Any) -> None:
        """(Executor thread.) Queue ``message``, dropping the oldest when full."""
        with self._lock:
            if len(self._queue) == self._queue.maxlen:
                self.dropped += 1
            self._queue.append(message)
            self.received += 1
            self.last = time.monotonic()
        self._wake()

    def take(self) -> list[Any]:
        """(Loop thread.) Every message waiting, oldest first."""
        with self._lock:
            out = list(self._queue)
            self._queue.clear()
        return out

    def latest(self) -> Any | None:
        """(Loop thread.) The newest message waiting, dropping the others (None: none)."""
        with self._lock:
            out = self._queue[-1] if self._queue else None
            self._queue.clear()
        return out

    def counters(self) -> dict[str, int]:
        """What came: ``keep`` (the queue's size: a topic of which only the newest message
        matters keeps 1 and drops the rest by design), ``received``, ``dropped``,
        ``undecodable``."""
        return {
            "keep": self._queue.maxlen or 0,
            "received": self.received,
            "dropped": self.dropped,
            "undecodable": self.undecodable,
        }


class Call:
    """A service call in flight: :meth:`done` once answered or timed out; :meth:`result`
    the response, or :class:`Ros2Error` naming the service when it failed or never
    answered. The request is sent once the service is found (a request sent before
    discovery matched it would be lost), both within ``timeout``; :meth:`done` (on the
    loop's thread) looks."""

    def __init__(self, service: str, client: Any, request: Any, timeout: float) -> None:
        self.service = service
        self._client = client
        self._request = request
        self._future: Any = None
        self._deadline = time.monotonic() + timeout
        self._timeout = timeout

    def _send(self) -> None:
        if self._future is None and self._client.service_is_ready():
            self._future = self._client.call_async(self._request)

    def done(self) -> bool:
        self._send()
        answered = self._future is not None and bool(self._future.done())
        return answered or time.monotonic() >= self._deadline

    def result(self) -> Any:
        self._send()
        future = self._future
        if future is not None and future.done():
            error = future.exception()
            if error is not None:
                raise Ros2Error(f"service {self.service}: the call failed: {error}")
            return future.result()
        if time.monotonic() >= self._deadline:
            if future is None:
                raise Ros2Error(f"service {self.service}: not found within {self._timeout:g} s")
            future.cancel()
            raise Ros2Error(f"service {self.service}: no answer within {self._timeout:g} s")
        raise Ros2Error(f"service {self.service}: not answered yet")


class RosNode:
    """A ROS 2 node named ``name`` in ``namespace``, spinning in its own thread once
    :meth:`start` ed, until :meth:`close`. ``wake`` (thread-safe, e.g. a :class:`Waker`) is
    called from the executor thread when messages or errors wait for the loop.
    ``domain_id`` None: ``ROS_DOMAIN_ID`` (or 0). :class:`~actorswarm.ros2.load.
    Ros2Unavailable` when there is no usable rclpy; :class:`Ros2Error` when the node cannot
    be made (a bad name)."""

    def __init__(
        self,
        name: str,
        namespace: str = "/",
        *,
        wake: Callable[[], None] | None = None,
        domain_id: int | None = None,
    ) -> None:
        rclpy = load_rclpy()
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor

        self._wake = wake or (lambda: None)
        self._errors: deque[str] = deque(maxlen=_ERRORS_KEPT)
        self._errors_lock = threading.Lock()
        #: Every error reported since the node was made, those dropped unread included.
        self.errors = 0
        self._context = Context()
        try:
            # No log files under ~/.ros: the daemon's own log says what happens.
            self._context.init(
                args=["--ros-args", "--disable-external-lib-logs"],
                domain_id=domain_id,
                initialize_logging=False,
            )
            self.node = rclpy.create_node(
                name, namespace=namespace, context=self._context, enable_rosout=False
            )
        except Exception as exc:  # rclpy raises its own error types for bad names
            self._context.try_shutdown()
            raise Ros2Error(f"ROS 2 node {namespace.rstrip('/')}/{name}: {exc}") from None
        self.name = self.node.get_fully_qualified_name()
        self._executor = SingleThreadedExecutor(context=self._context)
        self._executor.add_node(self.node)
        self._thread: threading.Thread | None = None
        self._publishers: dict[tuple[str, str], Any] = {}
        self._clients: dict[tuple[str, str], Any] = {}
        self.inlets: list[Inlet] = []
        self._closed = False
        self._graph_due = 0.0
        self._mismatches: set[tuple[str, tuple[str, ...]]] = set()

    # --- lifetime -----------------------------------------------------------------------

    def start(self) -> None:
        """Spin the node in its thread."""
        if self._thread is None:
            self._thread = threading.Thread(
                target=self._spin, name=f"ros2 {self.name}", daemon=True
            )
            self._thread.start()

    def _spin(self) -> None:
        from rclpy.executors import ExternalShutdownException

        try:
            self._executor.spin()
        except ExternalShutdownException:
            pass
        except Exception as exc:  # the executor died: say so, the loop runs on without it
            self.error(f"ROS 2 node {self.name}: its executor stopped: {exc}")

    def close(self) -> None:
        """Stop spinning and destroy the node (idempotent). Must be called before the
        process exits: an executor thread alive at exit aborts the interpreter."""
        if self._closed:
            return
        self._closed = True
        with contextlib.suppress(Exception):
            self._executor.shutdown(timeout_sec=1.0)
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        with contextlib.suppress(Exception):
            self.node.destroy_node()
        with contextlib.suppress(Exception):
            self._context.try_shutdown()

    @property
    def alive(self) -> bool:
        """True while the executor thread spins."""
        return not self._closed and self._thread is not None and self._thread.is_alive()

    # --- errors -------------------------------------------------------------------------

    def error(self, text: str) -> None:
        """(Any thread.) Report ``text`` to the loop (:meth:`drain_errors`)."""
        with self._errors_lock:
            self._errors.append(text)
            self.errors += 1
        self._wake()

    def drain_errors(self) -> list[str]:
        """(Loop thread.) The errors reported since the last call, oldest first; every
        :data:`_GRAPH_EVERY` seconds the graph is looked at too, for a subscribed topic
        that others publish with another type (not every rmw reports it as an event)."""
        now = time.monotonic()
        if now >= self._graph_due and self.inlets:
            self._graph_due = now + _GRAPH_EVERY
            self._check_types()
        with self._errors_lock:
            out = list(self._errors)
            self._errors.clear()
        return out

    def _check_types(self) -> None:
        try:
            graph = self.topic_types()
        except Exception:  # the node is going away
            return
        for inlet in self.inlets:
            others = [t for t in graph.get(inlet.topic, []) if t != inlet.type_name]
            if others and (inlet.topic, tuple(others)) not in self._mismatches:
                self._mismatches.add((inlet.topic, tuple(others)))
                self.error(
                    f"topic {inlet.topic}: published as {', '.join(others)}, subscribed as "
                    f"{inlet.type_name}: those messages are not received"
                )

    # --- topics -------------------------------------------------------------------------

    def resolve(self, name: str) -> str:
        """``name`` as the graph knows it (a relative name under the node's namespace)."""
        return str(self.node.resolve_topic_name(name))

    def subscribe(
        self,
        topic: str,
        type_name: str,
        *,
        qos: str = "reliable",
        keep: int = 100,
        wake: Callable[[], None] | None = None,
    ) -> Inlet:
        """Subscribe to ``topic`` of type ``type_name`` (``geometry_msgs/msg/PoseStamped``);
        its messages wait, decoded, in the returned :class:`Inlet`, at most ``keep``.
        ``wake`` instead of the node's own, for this topic. :class:`Ros2Error` naming the
        topic when the type is unknown or the name is not valid."""
        from rclpy.event_handler import SubscriptionEventCallbacks
        from rclpy.serialization import deserialize_message

        cls = message_type(type_name)
        if keep < 1:
            raise Ros2Error(f"topic {topic}: keep must be at least 1, not {keep}")
        inlet = Inlet(topic, type_name, keep, wake or self._wake)

        def on_message(raw: bytes) -> None:
            try:
                message = deserialize_message(raw, cls)
            except Exception as exc:
                inlet.undecodable += 1
                if inlet.undecodable == 1 or inlet.undecodable % 100 == 0:
                    self.error(
                        f"topic {inlet.topic}: a message did not decode as {type_name} "
                        f"({inlet.undecodable} so far): {exc}"
                    )
                return
            inlet.put(message)

        events = _events(
            SubscriptionEventCallbacks,
            lambda what: self.error(f"topic {inlet.topic}: {what} (subscribed as {type_name})"),
        )
        try:
            self.node.create_subscription(
                cls, topic, on_message, qos_profile(qos), raw=True, event_callbacks=events
            )
            inlet.topic = self.resolve(topic)
        except Ros2Error:
            raise
        except Exception as exc:
            raise Ros2Error(f"topic {topic}: cannot subscribe as {type_name}: {exc}") from None
        self.inlets.append(inlet)
        return inlet

    def publisher(self, topic: str, type_name: str, *, qos: str = "reliable") -> Any:
        """The publisher of ``topic`` (made once per topic and type)."""
        key = (topic, type_name)
        publisher = self._publishers.get(key)
        if publisher is None:
            from rclpy.event_handler import PublisherEventCallbacks

            cls = message_type(type_name)
            events = _events(
                PublisherEventCallbacks,
                lambda what: self.error(f"topic {topic}: {what} (published as {type_name})"),
            )
            try:
                publisher = self.node.create_publisher(
                    cls, topic, qos_profile(qos), event_callbacks=events
                )
            except Exception as exc:
                raise Ros2Error(f"topic {topic}: cannot publish {type_name}: {exc}") from None
            self._publishers[key] = publisher
        return publisher

    def publish(self, topic: str, type_name: str, message: Any, *, qos: str = "reliable") -> None:
        """Publish ``message`` on ``topic``."""
        try:
            self.publisher(topic, type_name, qos=qos).publish(message)
        except Ros2Error:
            raise
        except Exception as exc:
            raise Ros2Error(f"topic {topic}: cannot publish: {exc}") from None

    def now_msg(self) -> Any:
        """The node's clock now, as a ``builtin_interfaces/Time`` for a header's stamp."""
        return self.node.get_clock().now().to_msg()

    # --- services -----------------------------------------------------------------------

    def call(self, service: str, type_name: str, request: Any, *, timeout: float = 5.0) -> Call:
        """Call ``service`` (type ``type_name``, e.g. ``std_srvs/srv/Trigger``) with
        ``request``; returns at once (see :class:`Call`). A service that is not there yet
        is waited for within the same ``timeout``."""
        key = (service, type_name)
        client = self._clients.get(key)
        if client is None:
            try:
                client = self.node.create_client(message_type(type_name), service)
            except Ros2Error:
                raise
            except Exception as exc:
                raise Ros2Error(f"service {service}: cannot call it: {exc}") from None
            self._clients[key] = client
        return Call(self.resolve(service), client, request, timeout)

    def serve(
        self,
        service: str,
        type_name: str,
        loop: asyncio.AbstractEventLoop,
        handler: Callable[[Any, Any], Any],
        *,
        timeout: float = 5.0,
    ) -> None:
        """Answer ``service``: each request runs ``handler(request, response)`` on ``loop``
        (never on the executor thread), which fills and returns the response; a handler
        that takes over ``timeout`` seconds (a loop that is stopping) answers with rclpy's
        empty response."""
        import concurrent.futures

        def on_request(request: Any, response: Any) -> Any:
            done: concurrent.futures.Future[Any] = concurrent.futures.Future()

            def run() -> None:
                try:
                    done.set_result(handler(request, response))
                except Exception as exc:
                    done.set_exception(exc)

            try:
                loop.call_soon_threadsafe(run)
                return done.result(timeout=timeout)
            except Exception as exc:
                self.error(f"service {self.resolve(service)}: the request failed: {exc}")
                return response

        try:
            self.node.create_service(message_type(type_name), service, on_request)
        except Ros2Error:
            raise
        except Exception as exc:
            raise Ros2Error(f"service {service}: cannot serve it: {exc}") from None

    # --- graph --------------------------------------------------------------------------

    def topic_types(self) -> dict[str, list[str]]:
        """Every topic of the graph this node sees, with its types."""
        return {name: list(types) for name, types in self.node.get_topic_names_and_types()}


def _events(kind: Any, report: Callable[[str], None]) -> Any:
    """Event callbacks (of a subscription or publisher) that report a type or QoS mismatch
    instead of rclpy's log warning; ``incompatible_type`` only where the rclpy has it."""

    def qos(info: Any) -> None:
        report(f"incompatible QoS with another endpoint ({info.last_policy_kind})")

    def wrong_type(info: Any) -> None:
        report("another endpoint uses a different message type on it")

    try:
        return kind(incompatible_qos=qos, incompatible_type=wrong_type)
    except TypeError:  # an rclpy without the incompatible-type event
        return kind(incompatible_qos=qos)
