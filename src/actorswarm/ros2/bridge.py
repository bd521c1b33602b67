"""``actorswarm gs ros2``: the swarm as the ground station knows it, on ROS 2 topics.

Theory of operation
-------------------
A ground-station session (the one every ``gs`` command opens, with the operator's keys)
listens to the heartbeats and asks every platform heard for its status every ``poll``
seconds; a :class:`GroundView` keeps what the answers and the heartbeats say, and a
:class:`GroundBridge` publishes it with one ROS 2 node, ``/<swarm>/ground_bridge``. Per
platform N, under ``/<swarm>/pN/`` (what is sent, QoS):

=================  ======================================  ==========================
``pose``           ``geometry_msgs/PoseStamped``           reliable, each look
``fix``            ``sensor_msgs/NavSatFix``               reliable, each look (with
                                                           ``--origin`` only)
``actor``          ``std_msgs/String``: the running        latched, on change
                   actors, comma-separated ("" for none)
``roles``          ``std_msgs/String``: the roles the      latched, on change
                   platform holds, comma-separated
                   and sorted ("" for none)
``vehicle_state``  ``diagnostic_msgs/DiagnosticArray``:    reliable, on each status
                   the vehicle's own status entries
=================  ======================================  ==========================

and for the swarm, ``/<swarm>/master`` (``std_msgs/UInt16``, 0 while none is known;
latched, on change), ``/<swarm>/membership`` (``diagnostic_msgs/DiagnosticArray``: one
status per platform, ``OK`` joined, ``STALE`` left, ``WARN`` never heard; its values say
the incarnation, epoch, master flag, actors and roles) and ``/<swarm>/markers``
(``visualization_msgs/MarkerArray``: a sphere and a label per platform with a position,
for RViz and Foxglove). Poses are in one ENU frame of the mission (``--frame``, default
``map``: x east, y north, z up, metres from the mission's origin); with ``--origin
LAT,LON,ALT`` each pose is also a geodetic ``NavSatFix``.

The operator's actions are off unless ``--commands`` is given: a ROS 2 graph authenticates
no one, and with them on *anything that can reach the graph* (same domain, discovery range)
commands the swarm with the operator's authority, since the bridge signs what it sends with
the operator's key like any ``gs`` command. Then:

* ``/<swarm>/event`` (``std_msgs/String`` topic): the event named by ``data``, to every
  platform heard;
* ``/<swarm>/start`` (``std_srvs/Trigger``): start the script the platforms report;
* ``/<swarm>/pause`` and ``/<swarm>/activate`` (``std_srvs/Trigger``): pause every running
  actor, and activate again those the bridge paused;
* ``/<swarm>/pN/land``, ``hold``, ``resume`` (``std_srvs/Trigger``): the operator's
  ``vehicle_land`` / ``vehicle_hold`` / ``vehicle_resume`` events, to platform N only.

A service answers once the command is sent (``success`` false with the reason when it
could not be); the platforms' own answers come back on the status topics.
"""

from __future__ import annotations

import asyncio
import functools
import json
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from actorswarm.engine import commands as cmds
from actorswarm.ground import vehicle as vehicles
from actorswarm.ground.membership import Membership
from actorswarm.ground.station import GroundStation
from actorswarm.ros2 import messages as msgs
from actorswarm.ros2.load import message_type
from actorswarm.ros2.node import RosNode, Waker

__all__ = ["BridgeSettings", "GroundBridge", "GroundView", "Platform"]

#: Seconds a marker stays without being republished (a platform gone fades from RViz).
_MARKER_LIFETIME = 3.0

Act = Callable[[Callable[[GroundStation, float], Any]], Any]


@dataclass(frozen=True, slots=True)
class BridgeSettings:
    """``frame``: the mission's ENU frame id; ``origin``: its geodetic origin
    ``(lat, lon, alt)`` (None: no NavSatFix); ``commands``: the operator's actions."""

    frame: str = "map"
    origin: tuple[float, float, float] | None = None
    commands: bool = False


@dataclass(slots=True)
class Platform:
    """One platform as the ground station knows it."""

    platform: int
    state: str = "unheard"
    master: bool = False
    incarnation: int | None = None
    epoch: int | None = None
    position: tuple[float, float, float] | None = None
    actors: dict[str, str] = field(default_factory=dict)
    vehicle: dict[str, object] = field(default_factory=dict)
    script: str = ""
    #: When the task it runs began (UTC seconds; None: none, or not said).
    began: float | None = None
    #: The roles it holds (its latest status reply).
    roles: list[str] = field(default_factory=list)
    #: Whether a status reply of it came.
    answered: bool = False

    def running(self) -> list[str]:
        return [a for a, s in self.actors.items() if s == "running"]


class GroundView:
    """What the ground station knows of the swarm: membership from the heartbeats, the rest
    from the latest status reply of each platform (sans-IO: fed by :meth:`update`)."""

    def __init__(self, t_leave: float) -> None:
        self.membership = Membership(t_leave)
        self.platforms: dict[int, Platform] = {}
        self.master: int | None = None
        #: When the last status reply came (the station's clock; None: none yet).
        self.answered: float | None = None
        #: Platforms whose status changed since the last :meth:`take_changed`.
        self._changed: set[int] = set()

    def update(self, station: GroundStation, now: float) -> None:
        """Take in the station's new replies and look at the heartbeats."""
        for record in station.replies:
            reply = record.reply
            if isinstance(reply, cmds.StatusReply):
                p = self.platforms.setdefault(record.platform, Platform(record.platform))
                p.actors = dict(reply.actors)
                p.vehicle = dict(reply.vehicle)
                p.script = reply.script
                p.began = reply.began
                p.roles = sorted(reply.roles)
                p.answered = True
                self.answered = record.t
                if reply.position is not None and len(reply.position) >= 3:
                    x, y, z = reply.position[:3]
                    p.position = (float(x), float(y), float(z))
                self._changed.add(record.platform)
        station.replies.clear()
        self.membership.update(station, now)
        for number, member in self.membership.members.items():
            p = self.platforms.setdefault(number, Platform(number))
            p.state, p.master = member.state, member.master
            p.incarnation, p.epoch = member.incarnation, member.epoch
        self.master = self.membership.master()[0]

    def take_changed(self) -> set[int]:
        out, self._changed = self._changed, set()
        return out

    def alive(self) -> list[int]:
        return self.membership.alive()


class GroundBridge:
    """Publishes a :class:`GroundView` with ``node`` (see the module docstring)."""

    def __init__(self, node: RosNode, swarm: str, settings: BridgeSettings) -> None:
        self.node = node
        self.swarm = swarm
        self.settings = settings
        self.root = f"/{swarm}"
        self._actors: dict[int, str] = {}
        self._roles: dict[int, str] = {}
        self._master: int | None = -1
        self._served: set[int] = set()
        self._paused: dict[int, list[str]] = {}
        self._loop: asyncio.AbstractEventLoop | None = None
        self._act: Act | None = None
        self._view: GroundView | None = None
        #: What the operator's actions did, for the command's log (oldest first).
        self.actions: list[str] = []

    # --- publishing ---------------------------------------------------------------------

    def publish(self, view: GroundView) -> None:
        """Publish everything ``view`` says now (see the module docstring)."""
        self._view = view
        stamp = self.node.now_msg()
        frame = self.settings.frame
        for p in view.platforms.values():
            base = f"{self.root}/p{p.platform}"
            if p.position is not None:
                self.node.publish(
                    f"{base}/pose",
                    "geometry_msgs/msg/PoseStamped",
                    msgs.pose_stamped(stamp, frame, p.position),
                )
                if self.settings.origin is not None:
                    lat, lon, alt = _geodetic(p.position, self.settings.origin)
                    self.node.publish(
                        f"{base}/fix",
                        "sensor_msgs/msg/NavSatFix",
                        msgs.navsat(stamp, frame, lat, lon, alt),
                    )
            actor = ",".join(p.running())
            if self._actors.get(p.platform) != actor and (p.actors or p.platform in self._actors):
                self._actors[p.platform] = actor
                self.node.publish(
                    f"{base}/actor", "std_msgs/msg/String", msgs.string(actor), qos="latched"
                )
            roles = ",".join(p.roles)
            # Only once it answered: "" then says "holds none", not "not known yet".
            if p.answered and self._roles.get(p.platform) != roles:
                self._roles[p.platform] = roles
                self.node.publish(
                    f"{base}/roles", "std_msgs/msg/String", msgs.string(roles), qos="latched"
                )
            if self.settings.commands and p.platform not in self._served:
                self._serve_platform(p.platform)
        for number in view.take_changed():
            p = view.platforms[number]
            self.node.publish(
                f"{self.root}/p{number}/vehicle_state",
                "diagnostic_msgs/msg/DiagnosticArray",
                msgs.diagnostics(stamp, f"p{number}", p.vehicle, vehicles.alarm(p.vehicle)),
            )
        if view.master != self._master:
            self._master = view.master
            master = message_type("std_msgs/msg/UInt16")(data=view.master or 0)
            self.node.publish(f"{self.root}/master", "std_msgs/msg/UInt16", master, qos="latched")
        self.node.publish(
            f"{self.root}/membership",
            "diagnostic_msgs/msg/DiagnosticArray",
            self._membership(stamp, view),
        )
        self.node.publish(
            f"{self.root}/markers", "visualization_msgs/msg/MarkerArray", self._markers(stamp, view)
        )

    def _membership(self, stamp: Any, view: GroundView) -> Any:
        array = message_type("diagnostic_msgs/msg/DiagnosticArray")()
        status_cls = message_type("diagnostic_msgs/msg/DiagnosticStatus")
        pair = message_type("diagnostic_msgs/msg/KeyValue")
        level = {"joined": status_cls.OK, "left": status_cls.STALE, "unheard": status_cls.WARN}
        array.header.stamp = stamp
        for p in sorted(view.platforms.values(), key=lambda p: p.platform):
            status = status_cls()
            status.level = level.get(p.state, status_cls.WARN)
            status.name = f"p{p.platform}"
            status.hardware_id = f"p{p.platform}"
            status.message = p.state
            values = {
                "state": p.state,
                "master": p.master,
                "incarnation": p.incarnation,
                "epoch": p.epoch,
                "actors": json.dumps(p.actors),
                "roles": ",".join(p.roles),
            }
            status.values = [pair(key=k, value=str(v)) for k, v in values.items()]
            array.status.append(status)
        return array

    def _markers(self, stamp: Any, view: GroundView) -> Any:
        marker_cls = message_type("visualization_msgs/msg/Marker")
        array = message_type("visualization_msgs/msg/MarkerArray")()
        duration = message_type("builtin_interfaces/msg/Duration")
        lifetime = duration(sec=int(_MARKER_LIFETIME), nanosec=0)
        for p in view.platforms.values():
            if p.position is None:
                continue
            alarm = vehicles.alarm(p.vehicle)
            for kind, ns in (
                (marker_cls.SPHERE, "platforms"),
                (marker_cls.TEXT_VIEW_FACING, "labels"),
            ):
                m = marker_cls()
                m.header.stamp = stamp
                m.header.frame_id = self.settings.frame
                m.ns, m.id, m.type, m.action = ns, p.platform, kind, marker_cls.ADD
                m.pose.position.x, m.pose.position.y, m.pose.position.z = p.position
                m.pose.orientation.w = 1.0
                m.lifetime = lifetime
                if kind == marker_cls.SPHERE:
                    m.scale.x = m.scale.y = m.scale.z = 1.0
                    m.color.r, m.color.g, m.color.b = (
                        (0.9, 0.1, 0.1)
                        if alarm
                        else (0.1, 0.6, 0.9)
                        if p.master
                        else (0.2, 0.8, 0.2)
                    )
                else:
                    m.pose.position.z += 1.2
                    m.scale.z = 0.8
                    m.color.r = m.color.g = m.color.b = 1.0
                    m.text = f"p{p.platform} {','.join(p.running())}".strip()
                m.color.a = 1.0 if p.state == "joined" else 0.4
                array.markers.append(m)
        return array

    # --- the operator's actions ---------------------------------------------------------

    def enable_commands(self, loop: asyncio.AbstractEventLoop, act: Act) -> None:
        """Offer the operator's actions (``settings.commands`` must be on); ``act`` runs an
        action on the ground station and sends what it produced (on ``loop``)."""
        if not self.settings.commands:
            raise RuntimeError("the operator's actions are off (BridgeSettings.commands)")
        self._loop, self._act = loop, act
        self._event_inlet = self.node.subscribe(
            f"{self.root}/event", "std_msgs/msg/String", wake=Waker(loop, self._events)
        )
        trigger = "std_srvs/srv/Trigger"
        self.node.serve(f"{self.root}/start", trigger, loop, self._answer(self._start))
        self.node.serve(f"{self.root}/pause", trigger, loop, self._answer(self._pause))
        self.node.serve(f"{self.root}/activate", trigger, loop, self._answer(self._activate))

    def _serve_platform(self, platform: int) -> None:
        assert self._loop is not None
        self._served.add(platform)
        for name in ("land", "hold", "resume"):
            self.node.serve(
                f"{self.root}/p{platform}/{name}",
                "std_srvs/srv/Trigger",
                self._loop,
                self._answer(functools.partial(self._vehicle, platform, name)),
            )

    def _answer(self, action: Callable[[], tuple[bool, str]]) -> Callable[[Any, Any], Any]:
        def handler(request: Any, response: Any) -> Any:
            try:
                ok, text = action()
            except Exception as exc:  # a refusal of the station (nothing deployed...)
                ok, text = False, str(exc)
            self.actions.append(text)
            response.success, response.message = ok, text
            return response

        return handler

    def _events(self) -> None:
        for message in self._event_inlet.take():
            name = str(message.data).strip()
            try:
                cmds.Inject(event=name)  # the name's syntax, checked as the platforms will
                targets = self._targets()
                self._send_event(name, targets)
                self.actions.append(f"event {name} sent to platforms {targets}")
            except Exception as exc:
                self.node.error(f"topic {self.root}/event: event {name!r} not sent: {exc}")

    def _send_event(self, name: str, targets: list[int]) -> None:
        self._do(lambda st, now: st.event(name, now, platforms=targets))

    def _send(self, command: cmds.Command, platforms: list[int]) -> None:
        self._do(lambda st, now: st.send(command, platforms, now))

    def _targets(self) -> list[int]:
        return [] if self._view is None else self._view.alive()

    def _do(self, action: Callable[[GroundStation, float], Any]) -> Any:
        assert self._act is not None
        return self._act(action)

    def _start(self) -> tuple[bool, str]:
        view, targets = self._view, self._targets()
        scripts = {view.platforms[p].script for p in targets} if view else set()
        scripts.discard("")
        if len(scripts) != 1:
            return False, f"no start: the platforms heard report scripts {sorted(scripts)}"
        sha = scripts.pop()
        # The task's clock: the one the platforms already running it began (a platform
        # started now joins that task), else now.
        platforms = view.platforms.values() if view else ()
        began = [p.began for p in platforms if p.script == sha and p.began is not None]
        self._send(cmds.Start(sha256=sha, began=min(began, default=time.time())), targets)
        return True, f"start of script {sha[:12]} sent to platforms {targets}"

    def _pause(self) -> tuple[bool, str]:
        view = self._view
        sent = []
        for p in self._targets():
            running = view.platforms[p].running() if view else []
            for actor in running:
                self._send(cmds.Pause(actor=actor), [p])
            if running:
                self._paused[p] = running
                sent.append(p)
        return bool(sent), f"pause sent to platforms {sent}"

    def _activate(self) -> tuple[bool, str]:
        paused, self._paused = self._paused, {}
        for p, actors in paused.items():
            for actor in actors:
                self._send(cmds.Activate(actor=actor), [p])
        return bool(paused), f"activate sent to platforms {sorted(paused)}"

    def _vehicle(self, platform: int, what: str) -> tuple[bool, str]:
        event = f"vehicle_{what}"
        self._send_event(event, [platform])
        return True, f"{event} sent to platform {platform}"


def _geodetic(
    position: tuple[float, float, float], origin: tuple[float, float, float]
) -> tuple[float, float, float]:
    from actorswarm.vehicles.mavlink.frame import MissionFrame

    return MissionFrame(*origin).to_geodetic(*position)


def parse_origin(text: str) -> tuple[float, float, float]:
    """``LAT,LON,ALT`` degrees and metres; ValueError saying the form otherwise."""
    parts = text.split(",")
    try:
        lat, lon, alt = (float(v) for v in parts)
    except ValueError:
        raise ValueError(f"--origin {text!r}: write LAT,LON,ALT (47.3977,8.5456,488)") from None
    if not (-90 <= lat <= 90 and -180 <= lon <= 180 and math.isfinite(alt)):
        raise ValueError(f"--origin {text!r}: latitude or longitude out of range")
    return lat, lon, alt


def describe(settings: BridgeSettings, swarm: str) -> Mapping[str, str]:
    """What the bridge offers, for the command's first lines."""
    root = f"/{swarm}"
    out = {
        "poses": f"{root}/pN/pose (frame {settings.frame})",
        "swarm": f"{root}/master, {root}/membership, {root}/markers",
    }
    out["commands"] = (
        f"{root}/event, {root}/start|pause|activate, {root}/pN/land|hold|resume "
        "(signed with the operator's key: anyone on this ROS 2 graph commands the swarm)"
        if settings.commands
        else "off (--commands to offer them)"
    )
    return out
