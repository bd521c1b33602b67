"""The simulated world: vehicle physics, moving targets, areas and the radio's distance model.

Start with :func:`load_world` (a TOML world description, or the defaults) and
:class:`World` (everything advanced together in fixed steps of virtual time). Each
platform's vehicle is a :class:`SimVehicle`, the simulator's implementation of the
:class:`~actorswarm.runtime.context.Vehicle` interface plugins use. The modules:
:mod:`~actorswarm.world.config` (the description), :mod:`~actorswarm.world.vehicles`
(quadrotor and fixed-wing physics), :mod:`~actorswarm.world.targets` (the jeep),
:mod:`~actorswarm.world.radio_model` (loss and latency from positions) and
:mod:`~actorswarm.world.world`.
"""

from actorswarm.world.config import (
    KINDS,
    Area,
    FixedWingParams,
    FleetConfig,
    FleetGroup,
    Kind,
    QuadrotorParams,
    RadioConfig,
    TargetConfig,
    VehicleEntry,
    VehicleSpec,
    WorldConfig,
    WorldError,
    WorldSettings,
    load_world,
    loads_world,
    parse_platforms,
)
from actorswarm.world.radio_model import link, link_matrix, reachable
from actorswarm.world.targets import MovingTarget, Targets
from actorswarm.world.vehicles import MODES, Fleet, Mode, SimVehicle
from actorswarm.world.world import Track, World

__all__ = [
    "KINDS",
    "MODES",
    "Area",
    "FixedWingParams",
    "Fleet",
    "FleetConfig",
    "FleetGroup",
    "Kind",
    "Mode",
    "MovingTarget",
    "QuadrotorParams",
    "RadioConfig",
    "SimVehicle",
    "TargetConfig",
    "Targets",
    "Track",
    "VehicleEntry",
    "VehicleSpec",
    "World",
    "WorldConfig",
    "WorldError",
    "WorldSettings",
    "link",
    "link_matrix",
    "load_world",
    "loads_world",
    "parse_platforms",
    "reachable",
]
