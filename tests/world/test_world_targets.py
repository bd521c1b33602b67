"""Moving targets follow their routes at their speed, once or in a loop."""

from __future__ import annotations

import numpy as np
import pytest

from actorswarm.world import MovingTarget, TargetConfig, Targets

SQUARE = ((0.0, 0.0, 0.0), (100.0, 0.0, 0.0), (100.0, 100.0, 0.0), (0.0, 100.0, 0.0))


def jeep(**kwargs: object) -> MovingTarget:
    values: dict[str, object] = {"name": "jeep", "route": SQUARE, "speed": 5.0}
    values.update(kwargs)
    return MovingTarget(TargetConfig(**values))  # type: ignore[arg-type]


def test_a_looping_jeep_drives_round_its_route() -> None:
    target = jeep()
    assert target.route_length == 400.0
    assert target.position(0) == (0.0, 0.0, 0.0)
    assert target.position(10) == pytest.approx((50, 0, 0))
    assert target.position(20) == pytest.approx((100, 0, 0))
    assert target.position(30) == pytest.approx((100, 50, 0))
    assert target.position(70) == pytest.approx((0, 50, 0))  # the closing leg
    assert target.position(80) == pytest.approx((0, 0, 0))
    assert target.position(90) == pytest.approx((50, 0, 0))  # round again
    assert target.velocity(10) == pytest.approx((5, 0, 0))
    assert target.velocity(30) == pytest.approx((0, 5, 0))
    assert target.velocity(70) == pytest.approx((0, -5, 0))


def test_an_open_route_ends_at_its_last_waypoint() -> None:
    target = jeep(loop=False)
    assert target.route_length == 300.0
    assert target.position(59) == pytest.approx((5, 100, 0))
    assert target.position(60) == pytest.approx((0, 100, 0))
    assert target.position(1000) == pytest.approx((0, 100, 0))
    assert target.velocity(1000) == (0.0, 0.0, 0.0)
    assert target.velocity(59) == pytest.approx((-5, 0, 0))


def test_it_waits_for_its_start_time() -> None:
    target = jeep(start=10.0)
    assert target.position(5) == (0.0, 0.0, 0.0)
    assert target.velocity(5) == (0.0, 0.0, 0.0)
    assert target.position(12) == pytest.approx((10, 0, 0))


def test_speed_is_constant_along_the_route() -> None:
    target = jeep(route=((0, 0, 0), (30, 40, 0), (30, 40, 10), (-20, 0, 0)), speed=7.0)
    times = np.arange(0.0, 200.0, 0.01)
    positions = target.positions(times)
    step = np.linalg.norm(np.diff(positions, axis=0), axis=1)
    # Cutting a corner makes a step shorter, never longer.
    assert step.max() == pytest.approx(0.07)
    assert np.median(step) == pytest.approx(0.07)
    assert np.allclose(np.linalg.norm(target.velocities(times), axis=1), 7.0)


def test_the_vectorized_answers_match_the_scalar_ones() -> None:
    target = jeep(route=((0.0, 0.0, 0.0), (10.0, 5.0, 0.0)), speed=2.0)
    times = [0.0, 1.5, 3.0, 7.25, 20.0]
    for t, p in zip(times, target.positions(times), strict=True):
        assert target.position(t) == pytest.approx(tuple(p))


def test_still_targets() -> None:
    single = jeep(route=((5.0, 6.0, 0.0),))
    parked = jeep(speed=0.0)
    for t in (0.0, 10.0, 1e6):
        assert single.position(t) == (5.0, 6.0, 0.0)
        assert parked.position(t) == (0.0, 0.0, 0.0)
        assert single.velocity(t) == parked.velocity(t) == (0.0, 0.0, 0.0)


def test_targets_by_name_and_all_at_once() -> None:
    targets = Targets(
        [
            TargetConfig(name="jeep", route=SQUARE, speed=5.0),
            TargetConfig(name="truck", route=((0.0, 0.0, 0.0), (0.0, -50.0, 0.0)), speed=1.0),
        ]
    )
    assert len(targets) == 2 and targets.names == ("jeep", "truck")
    assert targets["truck"] is targets[1]
    assert targets.positions(10.0) == pytest.approx(np.array([[50, 0, 0], [0, -10, 0]]))
    assert targets.at(10.0)["jeep"] == pytest.approx((50, 0, 0))
    with pytest.raises(KeyError, match='did you mean "jeep"'):
        targets["jep"]
    assert Targets([]).positions(1.0).shape == (0, 3)
