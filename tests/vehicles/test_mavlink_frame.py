"""The mission frame: local ENU metres to and from WGS-84, and the origin's text form."""

from __future__ import annotations

import math

import pytest

from actorswarm.vehicles.mavlink.frame import MissionFrame, parse_origin

ORIGIN = MissionFrame(47.397742, 8.545594, 488.0)


def test_origin_is_zero_and_round_trip_is_exact() -> None:
    assert ORIGIN.to_local(ORIGIN.lat, ORIGIN.lon, ORIGIN.alt) == pytest.approx((0, 0, 0), abs=1e-6)
    for point in [(120.0, -45.0, 30.0), (-800.0, 950.0, 2.5), (0.0, 0.0, 100.0)]:
        back = ORIGIN.to_local(*ORIGIN.to_geodetic(*point))
        assert back == pytest.approx(point, abs=1e-6)


def test_axes_are_east_north_up() -> None:
    lat, lon, _ = ORIGIN.to_geodetic(0.0, 100.0, 0.0)
    # 100 m north: about 0.0009 degrees of latitude at 47 degrees, the same longitude.
    assert lat - ORIGIN.lat == pytest.approx(100.0 / 111_190, rel=0.01)
    assert lon == pytest.approx(ORIGIN.lon, abs=1e-9)
    lat, lon, _ = ORIGIN.to_geodetic(100.0, 0.0, 0.0)
    # 100 m east: a degree of longitude is shorter by cos(latitude).
    per_degree = 111_320 * math.cos(math.radians(ORIGIN.lat))
    assert lon - ORIGIN.lon == pytest.approx(100.0 / per_degree, rel=0.01)
    assert lat == pytest.approx(ORIGIN.lat, abs=1e-6)
    assert ORIGIN.to_geodetic(0.0, 0.0, 25.0)[2] == pytest.approx(ORIGIN.alt + 25.0, abs=1e-3)


def test_parse_origin() -> None:
    assert parse_origin("47.5, 8.5, 400") == MissionFrame(47.5, 8.5, 400.0)
    for text, word in [
        ("47.5,8.5", "LAT,LON,ALT"),
        ("north,8.5,400", "three numbers"),
        ("95,8.5,400", "latitude"),
        ("45,190,0", "longitude"),
        ("45,nan,0", "finite"),
    ]:
        with pytest.raises(ValueError, match=word):
            parse_origin(text)


@pytest.mark.parametrize(
    "origin",
    [ORIGIN, MissionFrame(-33.9, 151.2, 40.0), MissionFrame(78.2, 15.6, 5.0),
     MissionFrame(0.0, -179.9, 0.0), MissionFrame(89.9, 0.0, 2000.0)],
)  # fmt: skip
def test_the_conversion_agrees_with_pymap3d(origin: MissionFrame) -> None:
    pymap3d = pytest.importorskip("pymap3d")
    for point in [(0.0, 0.0, 0.0), (120.0, -45.0, 30.0), (-5000.0, 4000.0, 300.0)]:
        want = pymap3d.enu2geodetic(*point, origin.lat, origin.lon, origin.alt)
        lat, lon, alt = origin.to_geodetic(*point)
        assert (lat, lon) == pytest.approx((float(want[0]), float(want[1])), abs=1e-9)
        assert alt == pytest.approx(float(want[2]), abs=1e-4)
        local = pymap3d.geodetic2enu(lat, lon, alt, origin.lat, origin.lon, origin.alt)
        assert origin.to_local(lat, lon, alt) == pytest.approx(
            tuple(float(v) for v in local), abs=1e-4
        )
