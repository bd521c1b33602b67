"""The simulated camera: which targets a vehicle sees, from the world's geometry.

Theory of operation
-------------------
Every vehicle carries one camera looking straight down (``[camera]`` in the world file,
:class:`~actorswarm.world.config.CameraConfig`). A target is *in view* when

* the vehicle is at least ``min_altitude`` up and alive (a dead vehicle's camera is off),
* the angle between straight down and the line to the target is at most half the field of
  view — on flat ground, the target is inside the *footprint*, a disc of radius
  ``altitude · tan(field_of_view / 2)`` under the vehicle — and
* the target is at most ``max_range`` metres away.

Detection is geometric and noise-free, so a seeded run replays exactly; the position a
:class:`~actorswarm.runtime.context.Detection` reports is the target's true position (a
real detector's adapter would report its estimate). :func:`detect` is the pure geometry,
shared with :class:`actorswarm.testing.FakeCamera`; :class:`SimCamera` asks the world for
the vehicle and the targets at the world's current time.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Protocol

from actorswarm.runtime.context import Detection
from actorswarm.world.config import CameraConfig, WorldConfig
from actorswarm.world.targets import Targets
from actorswarm.world.vehicles import SimVehicle

__all__ = ["Scene", "SimCamera", "detect", "footprint_radius"]

Point3 = tuple[float, float, float]


def footprint_radius(altitude: float, camera: CameraConfig) -> float:
    """The radius, metres, of the ground disc a camera at ``altitude`` sees (0 below
    ``min_altitude``); capped where the slant range reaches ``max_range``."""
    if altitude < camera.min_altitude or altitude <= 0.0:
        return 0.0
    radius = altitude * math.tan(math.radians(camera.field_of_view / 2.0))
    if altitude >= camera.max_range:
        return 0.0
    return min(radius, math.sqrt(camera.max_range**2 - altitude**2))


def detect(
    position: Point3,
    targets: Iterable[tuple[str, str, Point3]],
    camera: CameraConfig,
) -> list[Detection]:
    """The ``(name, kind, position)`` targets a camera at ``position`` sees, nearest first
    (ties by name, so the order is deterministic)."""
    x, y, z = position
    if z < camera.min_altitude:
        return []
    half = math.radians(camera.field_of_view / 2.0)
    out = []
    for name, kind, (tx, ty, tz) in targets:
        depth = z - tz  # how far below the camera the target is
        if depth <= 0.0:
            continue
        distance = math.dist((x, y, z), (tx, ty, tz))
        if distance > camera.max_range:
            continue
        if math.atan2(math.hypot(tx - x, ty - y), depth) > half:
            continue
        out.append(Detection(name=name, kind=kind, position=(tx, ty, tz), distance=distance))
    out.sort(key=lambda d: (d.distance, d.name))
    return out


class Scene(Protocol):
    """What a camera needs of the world (:class:`~actorswarm.world.world.World` is one):
    the vehicles, the targets where they are now, the camera's configuration."""

    @property
    def config(self) -> WorldConfig: ...

    @property
    def targets(self) -> Targets: ...

    def vehicle(self, platform: int) -> SimVehicle: ...

    def target_positions(self) -> dict[str, Point3]: ...


class SimCamera:
    """The :class:`~actorswarm.runtime.context.Camera` of ``platform``'s vehicle in
    ``world``, at the world's current time."""

    __slots__ = ("_platform", "_world")

    def __init__(self, world: Scene, platform: int) -> None:
        world.vehicle(platform)  # KeyError now, not at the first frame
        self._world = world
        self._platform = platform

    def __repr__(self) -> str:
        return f"SimCamera(platform={self._platform})"

    def _alive_position(self) -> Point3 | None:
        vehicle = self._world.vehicle(self._platform)
        if vehicle.mode == "dead":
            return None
        return vehicle.position()

    def detections(self) -> list[Detection]:
        position = self._alive_position()
        if position is None:
            return []
        world = self._world
        now = world.target_positions()
        return detect(
            position,
            ((t.name, t.kind, now[t.name]) for t in world.targets),
            world.config.camera,
        )

    def footprint(self) -> float:
        position = self._alive_position()
        if position is None:
            return 0.0
        return footprint_radius(position[2], self._world.config.camera)
