"""The mission's local frame and geodetic coordinates.

A swarm shares one mission origin (latitude, longitude in degrees, altitude in metres above
mean sea level): x is metres east of it, y metres north, z metres up — the frame every
plugin speaks (:class:`~actorswarm.runtime.context.Vehicle`). Autopilots speak WGS-84
latitude, longitude and altitude; each adapter converts with :class:`MissionFrame`, never
with each autopilot's own EKF origin (which differs from one vehicle to the next).
The conversion is pymap3d's ENU, exact on the ellipsoid (no flat-earth approximation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pymap3d

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
        lat, lon, alt = pymap3d.enu2geodetic(x, y, z, self.lat, self.lon, self.alt)
        return (float(lat), float(lon), float(alt))

    def to_local(self, lat: float, lon: float, alt: float) -> tuple[float, float, float]:
        """``(x, y, z)`` of the geodetic point ``(lat, lon, alt)``."""
        x, y, z = pymap3d.geodetic2enu(lat, lon, alt, self.lat, self.lon, self.alt)
        return (float(x), float(y), float(z))


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
