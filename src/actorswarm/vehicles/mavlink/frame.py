"""The mission's local frame and geodetic coordinates.

A swarm shares one mission origin (latitude, longitude in degrees, altitude in metres above
mean sea level): x is metres east of it, y metres north, z metres up — the frame every
plugin speaks (:class:`~actorswarm.runtime.context.Vehicle`). Autopilots speak WGS-84
latitude, longitude and altitude; each adapter converts with :class:`MissionFrame`, never
with each autopilot's own EKF origin (which differs from one vehicle to the next).
The conversion is exact on the WGS-84 ellipsoid (no flat-earth approximation): geodetic to
Earth-centred Earth-fixed coordinates and back, rotated into the origin's east-north-up
axes. Written here rather than taken from pymap3d, which loads NumPy (17 MiB of a daemon's
memory for six trigonometric lines); the tests check it against pymap3d to 0.1 mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["MissionFrame", "parse_origin"]


@dataclass(frozen=True, slots=True)
class MissionFrame:
    """The local frame whose origin is ``(lat, lon, alt)``: degrees, degrees, metres AMSL."""

    lat: float
    lon: float
    alt: float

    def __post_init__(self) -> None:
        values = (self.lat, self.lon, self.alt)
        if not all(isinstance(v, int | float) and math.isfinite(v) for v in values):
            raise ValueError(f"origin: three finite numbers (lat, lon, alt), not {values!r}")
        if not -90.0 <= self.lat <= 90.0:
            raise ValueError(f"origin: latitude {self.lat} is not within -90..90 degrees")
        if not -180.0 <= self.lon <= 180.0:
            raise ValueError(f"origin: longitude {self.lon} is not within -180..180 degrees")

    def to_geodetic(self, x: float, y: float, z: float) -> tuple[float, float, float]:
        """``(lat, lon, alt)`` of the local point ``(x, y, z)``."""
        ox, oy, oz = _ecef(self.lat, self.lon, self.alt)
        dx, dy, dz = _enu_to_ecef_delta(x, y, z, self.lat, self.lon)
        return _geodetic(ox + dx, oy + dy, oz + dz)

    def to_local(self, lat: float, lon: float, alt: float) -> tuple[float, float, float]:
        """``(x, y, z)`` of the geodetic point ``(lat, lon, alt)``."""
        px, py, pz = _ecef(lat, lon, alt)
        ox, oy, oz = _ecef(self.lat, self.lon, self.alt)
        return _ecef_delta_to_enu(px - ox, py - oy, pz - oz, self.lat, self.lon)


#: WGS-84: the semi-major axis (m) and the first eccentricity squared.
_A = 6378137.0
_F = 1 / 298.257223563
_E2 = _F * (2 - _F)
_B = _A * (1 - _F)
_EP2 = (_A * _A - _B * _B) / (_B * _B)


def _ecef(lat: float, lon: float, alt: float) -> tuple[float, float, float]:
    phi, lam = math.radians(lat), math.radians(lon)
    sin_phi = math.sin(phi)
    n = _A / math.sqrt(1 - _E2 * sin_phi * sin_phi)
    return (
        (n + alt) * math.cos(phi) * math.cos(lam),
        (n + alt) * math.cos(phi) * math.sin(lam),
        (n * (1 - _E2) + alt) * sin_phi,
    )


def _geodetic(x: float, y: float, z: float) -> tuple[float, float, float]:
    """ECEF to latitude, longitude, altitude: Bowring's formula, refined by iteration (a
    few steps reach far below a millimetre near the surface)."""
    lam = math.atan2(y, x)
    p = math.hypot(x, y)
    theta = math.atan2(z * _A, p * _B)
    phi = math.atan2(z + _EP2 * _B * math.sin(theta) ** 3, p - _E2 * _A * math.cos(theta) ** 3)
    alt = 0.0
    for _ in range(4):
        alt = _height(phi, p, z)
        phi = math.atan2(z, p * (1 - _E2 * _prime_vertical(phi) / (_prime_vertical(phi) + alt)))
    alt = _height(phi, p, z)
    return (math.degrees(phi), math.degrees(lam), alt)


def _prime_vertical(phi: float) -> float:
    sin_phi = math.sin(phi)
    return _A / math.sqrt(1 - _E2 * sin_phi * sin_phi)


def _height(phi: float, p: float, z: float) -> float:
    """The height above the ellipsoid of a point at latitude ``phi`` (radians), ``p``
    metres from the axis, ``z`` above the equator's plane."""
    cos_phi = math.cos(phi)
    if abs(cos_phi) > 1e-9:
        return p / cos_phi - _prime_vertical(phi)
    return abs(z) - _B  # at a pole


def _enu_to_ecef_delta(
    e: float, n: float, u: float, lat: float, lon: float
) -> tuple[float, float, float]:
    phi, lam = math.radians(lat), math.radians(lon)
    sp, cp, sl, cl = math.sin(phi), math.cos(phi), math.sin(lam), math.cos(lam)
    return (
        -sl * e - sp * cl * n + cp * cl * u,
        cl * e - sp * sl * n + cp * sl * u,
        cp * n + sp * u,
    )


def _ecef_delta_to_enu(
    dx: float, dy: float, dz: float, lat: float, lon: float
) -> tuple[float, float, float]:
    phi, lam = math.radians(lat), math.radians(lon)
    sp, cp, sl, cl = math.sin(phi), math.cos(phi), math.sin(lam), math.cos(lam)
    return (
        -sl * dx + cl * dy,
        -sp * cl * dx - sp * sl * dy + cp * dz,
        cp * cl * dx + cp * sl * dy + sp * dz,
    )


def parse_origin(text: str, what: str = "origin") -> MissionFrame:
    """The frame of an origin written ``LAT,LON,ALT`` (degrees, degrees, metres AMSL);
    ValueError naming ``what`` (the option) and what is wrong."""
    parts = [p.strip() for p in text.split(",")]
    if len(parts) != 3:
        raise ValueError(f"{what} {text!r}: write it LAT,LON,ALT (degrees, degrees, metres)")
    try:
        lat, lon, alt = (float(p) for p in parts)
    except ValueError:
        raise ValueError(f"{what} {text!r}: LAT,LON,ALT must be three numbers") from None
    try:
        return MissionFrame(lat, lon, alt)
    except ValueError as exc:
        raise ValueError(f"{what} {text!r}: {str(exc).removeprefix('origin: ')}") from None
