"""The simulated camera: what a vehicle sees, from the world's geometry."""

from __future__ import annotations

import math

import pytest

from actorswarm.world.config import CameraConfig, WorldError, loads_world
from actorswarm.world.sensors import detect, footprint_radius
from actorswarm.world.world import World

CAMERA = CameraConfig(field_of_view=90.0, max_range=200.0, min_altitude=2.0)


def test_the_footprint_is_a_disc_of_altitude_times_tan_half_fov() -> None:
    assert footprint_radius(20.0, CAMERA) == pytest.approx(20.0)
    narrow = CameraConfig(field_of_view=60.0)
    assert footprint_radius(30.0, narrow) == pytest.approx(30.0 * math.tan(math.radians(30)))
    assert footprint_radius(1.0, CAMERA) == 0.0, "below min_altitude it sees nothing"
    # Capped where the slant range reaches max_range: at 150 m up, sqrt(200² - 150²).
    assert footprint_radius(150.0, CAMERA) == pytest.approx(math.sqrt(200**2 - 150**2))
    assert footprint_radius(250.0, CAMERA) == 0.0


@pytest.mark.parametrize(
    ("target", "seen"),
    [
        ((19.5, 0.0, 0.0), True),
        ((20.5, 0.0, 0.0), False),  # just outside the 20 m footprint at 20 m up
        ((0.0, 0.0, 0.0), True),
        ((0.0, 0.0, 25.0), False),  # above the camera
    ],
)
def test_a_target_is_seen_only_inside_the_footprint(
    target: tuple[float, float, float], seen: bool
) -> None:
    found = detect((0.0, 0.0, 20.0), [("jeep", "jeep", target)], CAMERA)
    assert bool(found) is seen
    if seen:
        assert found[0].distance == pytest.approx(math.dist((0.0, 0.0, 20.0), target))


def test_detections_come_nearest_first() -> None:
    targets = [("far", "jeep", (10.0, 0.0, 0.0)), ("near", "jeep", (1.0, 0.0, 0.0))]
    assert [d.name for d in detect((0.0, 0.0, 20.0), targets, CAMERA)] == ["near", "far"]


def test_a_bad_camera_section_is_refused_with_its_key() -> None:
    with pytest.raises(WorldError, match="field_of_view"):
        loads_world("[camera]\nfield_of_view = 180.0\n")
    with pytest.raises(WorldError, match="did you mean"):
        loads_world("[camera]\nfield_of_veiw = 90.0\n")


WORLD = """
[[targets]]
name = "jeep"
route = [[0.0, 0.0]]
speed = 0.0

[[areas]]
name = "search"
rect = [-10.0, -10.0, 10.0, 10.0]

[quadrotor]
endurance = 20.0
"""


def test_the_world_s_camera_follows_its_vehicle_and_a_dead_one_sees_nothing() -> None:
    world = World(loads_world(WORLD), [1])
    camera = world.camera(1)
    assert camera.detections() == [], "on the ground"
    world.vehicle(1).takeoff(10.0)
    world.step_to(8.0)
    assert [d.name for d in camera.detections()] == ["jeep"]
    assert camera.footprint() == pytest.approx(world.vehicle(1).position()[2], rel=1e-6)
    assert world.area_polygons()["search"][0] == (-10.0, -10.0)
    assert world.wrecked() == []
    world.step_to(60.0)  # 20 s of endurance: the battery is empty, the vehicle falls
    assert world.vehicle(1).mode == "dead"
    assert camera.detections() == [] and camera.footprint() == 0.0
    assert world.wrecked() == [1]
