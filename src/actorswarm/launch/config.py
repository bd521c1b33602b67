"""The launch file (``actorswarm launch SWARM.toml``): a swarm of daemons on this machine.

One TOML file says which platforms to start and how; every key is optional but
``platforms``. Relative paths are relative to the file's directory::

    swarm = "branch-merge"      # the swarm's name (its Zenoh namespace)
    platforms = "1-10"          # the platform IDs: "1-10", "1,3,5-7", or a list
    directory = "run"           # state directories (run/state-ID) and logs (run/daemon-ID.log)
    keys = "keys"               # the key directory (default: the user's); or insecure = true
    multicast = false           # false (default): each daemon listens on host:port and
    host = "127.0.0.1"          #   connects to the ones before it; true: multicast scouting
    ports = 7501                # the first of consecutive ports, or one per platform [7501, ...];
                                #   default: free ports chosen at launch
    vehicle = "sim"             # "none" (default), "sim" or "mavlink" (see below)
    world = "world.toml"        # the simulated vehicles' world (default: the default world)
    config = "daemon.toml"      # a daemon configuration file every daemon reads (--config)
    web = 8765                  # also serve the web ground station on 127.0.0.1:8765
                                #   (true: that port; default: no page)

    [platform.3]                # overrides for one platform (or a range: [platform."4-6"])
    vehicle = "none"
    state_dir = "/tmp/three"
    config = "three.toml"

With ``vehicle = "mavlink"`` each daemon flies an autopilot, started by the launcher from
a command template or already running: the ``origin`` key and the ``[autopilot]`` table
(:mod:`actorswarm.launch.autopilots`).

With ``vehicle = "sim"`` every daemon gets ``--fleet`` with all the launched platforms, so
each vehicle starts at its home of the world's fleet layout, as in the simulator.

:func:`load_launch` reads and checks the file; every problem is a :class:`LaunchError`
naming the file, the key and, where the file says it, the line.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final

from actorswarm.launch.autopilots import AutopilotSpec, read_autopilots
from actorswarm.suggest import did_you_mean

__all__ = ["LaunchError", "LaunchFile", "PlatformPlan", "load_launch"]

_TOP: Final = frozenset(
    {"swarm", "platforms", "directory", "keys", "insecure", "multicast", "host", "ports",
     "vehicle", "world", "config", "platform", "web", "origin", "autopilot"}
)  # fmt: skip
_PER_PLATFORM: Final = frozenset({"vehicle", "world", "config", "state_dir"})
_VEHICLES: Final = ("none", "sim", "mavlink")
_MAX_PLATFORM: Final = 65535
#: ``web = true``: the web ground station's usual port (``actorswarm gs web``).
WEB_PORT: Final = 8765


class LaunchError(ValueError):
    """The launch file cannot be used: the message names the file, the key and the line
    when known."""


@dataclass(frozen=True, slots=True)
class PlatformPlan:
    """How one platform's daemon starts."""

    platform: int
    vehicle: str
    world: Path | None
    config: Path | None
    state_dir: Path


@dataclass(frozen=True, slots=True)
class LaunchFile:
    """A checked launch file."""

    source: Path
    swarm: str
    directory: Path
    keys: Path | None
    insecure: bool
    multicast: bool
    host: str
    #: One port per platform, in ``plans`` order; empty: chosen at launch (or multicast).
    ports: tuple[int, ...]
    plans: tuple[PlatformPlan, ...] = field(default=())
    #: The port of the web ground station on 127.0.0.1 to serve with the swarm; None: none.
    web: int | None = None
    #: ``vehicle = "mavlink"``: the autopilots (None: no platform flies one).
    autopilots: AutopilotSpec | None = None

    def mavlink_platforms(self) -> list[int]:
        """The platforms that fly an autopilot, in order (their instance index)."""
        return [plan.platform for plan in self.plans if plan.vehicle == "mavlink"]

    @property
    def platforms(self) -> list[int]:
        return [plan.platform for plan in self.plans]

    def shared_world(self) -> Path | None:
        """The world file every simulated vehicle flies in, when they share one (what the
        web ground station launched beside them draws and checks deployed scripts against);
        None when no vehicle is simulated, one flies the default world, or they differ."""
        worlds = {plan.world for plan in self.plans if plan.vehicle == "sim"}
        return worlds.pop() if len(worlds) == 1 else None

    def daemon_args(self, plan: PlatformPlan) -> list[str]:
        """The daemon options of ``plan`` that the file sets (the swarm, endpoints, keys
        and state directory come from :class:`~actorswarm.daemon.launch.LocalSwarm`)."""
        args: list[str] = []
        if plan.vehicle == "sim":
            args += ["--vehicle", "sim", "--fleet", ",".join(map(str, self.platforms))]
            if plan.world is not None:
                args += ["--world", str(plan.world)]
        if plan.vehicle == "mavlink" and self.autopilots is not None:
            spec = self.autopilots
            index = self.mavlink_platforms().index(plan.platform)
            args += ["--vehicle", "mavlink", "--mavlink", spec.link(index, plan.platform),
                     "--mavlink-sysid", str(plan.platform),
                     "--origin", ",".join(str(v) for v in spec.origin)]  # fmt: skip
        if plan.config is not None:
            args += ["--config", str(plan.config)]
        return args


def _line_of(text: str, key: str, table: str | None = None) -> str:
    """``:LINE`` of the first line that sets ``key`` (inside ``[table]`` when given), or
    empty when the file does not show it plainly."""
    inside = table is None
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if stripped.startswith("["):
            header = stripped.strip("[] ").replace('"', "")
            inside = table is None or header == table
            continue
        if inside and re.match(rf'"?{re.escape(key)}"?\s*=', stripped):
            return f":{number}"
    return ""


def _ids(value: object) -> list[int]:
    """Platform IDs from an integer, a list of integers or a string of IDs and ranges."""
    if isinstance(value, bool):
        raise ValueError("expected platform IDs, not true/false")
    if isinstance(value, int):
        parts: list[object] = [value]
    elif isinstance(value, list):
        parts = list(value)
    elif isinstance(value, str):
        parts = [p.strip() for p in value.split(",") if p.strip()]
    else:
        raise ValueError(f'expected IDs such as "1-10" or [1, 2], not {value!r}')
    out: list[int] = []
    for part in parts:
        if isinstance(part, bool) or not isinstance(part, int | str):
            raise ValueError(f"{part!r} is not a platform ID")
        low, dash, high = str(part).partition("-")
        try:
            first, last = int(low), int(high) if dash else int(low)
        except ValueError:
            raise ValueError(f'{part!r} is not a platform ID or range (e.g. "1-10")') from None
        if not 1 <= first <= last <= _MAX_PLATFORM:
            raise ValueError(f"{part!r}: platform IDs are 1..{_MAX_PLATFORM}, low to high")
        out += range(first, last + 1)
    if len(set(out)) != len(out):
        raise ValueError("a platform is named twice")
    if not out:
        raise ValueError("names no platform")
    return sorted(out)


class _Reader:
    """Typed access to the parsed file, with errors that name the key and its line."""

    def __init__(self, path: Path, text: str) -> None:
        self.file, self.text = path, text

    def fail(self, key: str, problem: str, table: str | None = None) -> LaunchError:
        line = _line_of(self.text, key.rsplit(".", 1)[-1], table)
        return LaunchError(f"{self.file}{line}: {key}: {problem}")

    def get(self, data: dict[str, Any], key: str, kind: type, where: str = "") -> Any:
        value = data.get(key)
        if value is None:
            return None
        if (kind is int and isinstance(value, bool)) or not isinstance(value, kind):
            name = {str: "a string", bool: "true or false", int: "an integer"}[kind]
            raise self.fail(f"{where}{key}", f"expected {name}, not {value!r}", where[:-1] or None)
        return value

    def path(self, data: dict[str, Any], key: str, where: str = "") -> Path | None:
        value = self.get(data, key, str, where)
        if value is None:
            return None
        p = Path(value).expanduser()
        return p if p.is_absolute() else self.path_base / p

    @property
    def path_base(self) -> Path:
        return self.file.resolve().parent

    def unknown(self, data: dict[str, Any], known: frozenset[str], table: str | None) -> None:
        for key in data:
            if key not in known:
                where = f"[{table}] " if table else ""
                raise self.fail(
                    key,
                    f"unknown key {where}{key!r}{did_you_mean(key, sorted(known))}; "
                    f"the keys are: {', '.join(sorted(known))}",
                    table,
                )


def load_launch(path: Path) -> LaunchFile:
    """Read and check the launch file at ``path`` (LaunchError on any problem)."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise LaunchError(f"{path}: cannot read: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise LaunchError(f"{path}: not UTF-8 text") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        found = re.search(r"at line (\d+)", str(exc))
        line = f":{found.group(1)}" if found else ""
        raise LaunchError(f"{path}{line}: not TOML: {exc}") from None
    r = _Reader(path, text)
    r.unknown(data, _TOP, None)
    if "platforms" not in data:
        raise LaunchError(f'{path}: platforms: missing; say which to start, e.g. "1-10"')
    try:
        platforms = _ids(data["platforms"])
    except ValueError as exc:
        raise r.fail("platforms", str(exc)) from None
    swarm = r.get(data, "swarm", str) or "swarm"
    from actorswarm.transport.zenoh_transport import key_prefix

    try:
        key_prefix(swarm)
    except ValueError as exc:
        raise r.fail("swarm", str(exc)) from None
    insecure = bool(r.get(data, "insecure", bool))
    keys = r.path(data, "keys")
    if insecure and keys is not None:
        raise r.fail("insecure", "keys and insecure = true exclude each other")
    multicast = bool(r.get(data, "multicast", bool))
    host = r.get(data, "host", str) or "127.0.0.1"
    ports = _ports(r, data.get("ports"), len(platforms))
    if multicast and ports:
        raise r.fail("ports", "multicast = true finds the peers without ports: remove one")
    directory = r.path(data, "directory") or r.path_base / f"launch-{swarm}"
    web = _web(r, data.get("web"))
    default = _plan_values(r, data, "")
    overrides = _overrides(r, data.get("platform", {}), platforms)
    plans = []
    if default.get("world") is not None and default.get("vehicle") != "sim":
        raise r.fail("world", 'a world is for simulated vehicles: say vehicle = "sim" too')
    for pid in platforms:
        own = overrides.get(pid, {})
        values = {**default, **own}
        vehicle = values.get("vehicle") or "none"
        if own.get("world") is not None and vehicle != "sim":
            raise r.fail("world", f'platform {pid}: a world needs vehicle = "sim"')
        if vehicle != "sim":
            values["world"] = None  # the swarm's world is for its simulated vehicles
        plans.append(
            PlatformPlan(
                platform=pid,
                vehicle=vehicle,
                world=values.get("world"),
                config=values.get("config"),
                state_dir=values.get("state_dir") or directory / f"state-{pid}",
            )
        )
    autopilots: AutopilotSpec | None = None
    flying = [plan.platform for plan in plans if plan.vehicle == "mavlink"]
    table = data.get("autopilot")
    if table is not None and not isinstance(table, dict):
        raise r.fail("autopilot", "expected a table [autopilot]")
    if flying:
        spec = read_autopilots(table or {}, r.get(data, "origin", str), flying)
        if isinstance(spec, str):
            key = spec.split(":", 1)[0]
            raise LaunchError(f"{path}{_line_of(text, key.rsplit('.', 1)[-1])}: {spec}")
        autopilots = spec
    elif table is not None or "origin" in data:
        raise r.fail(
            "autopilot" if table is not None else "origin",
            'for autopilots: say vehicle = "mavlink" too',
        )
    return LaunchFile(
        source=path,
        swarm=swarm,
        directory=directory,
        keys=keys,
        insecure=insecure,
        multicast=multicast,
        host=host,
        ports=ports,
        plans=tuple(plans),
        web=web,
        autopilots=autopilots,
    )


def _web(r: _Reader, value: object) -> int | None:
    if value is None or value is False:
        return None
    if value is True:
        return WEB_PORT
    if isinstance(value, int) and 1 <= value <= 65535:
        return value
    raise r.fail("web", f"expected true, false or a port (1..65535), not {value!r}")


def _ports(r: _Reader, value: object, count: int) -> tuple[int, ...]:
    if value is None:
        return ()
    if isinstance(value, int) and not isinstance(value, bool):
        ports = list(range(value, value + count))
    elif isinstance(value, list) and all(
        isinstance(v, int) and not isinstance(v, bool) for v in value
    ):
        ports = list(value)
        if len(ports) != count:
            raise r.fail("ports", f"{len(ports)} ports for {count} platforms")
    else:
        raise r.fail("ports", f"expected a first port or a list of ports, not {value!r}")
    if any(not 1 <= p <= 65535 for p in ports):
        raise r.fail("ports", "ports are 1..65535")
    if len(set(ports)) != len(ports):
        raise r.fail("ports", "a port is given twice")
    return tuple(ports)


def _plan_values(r: _Reader, data: dict[str, Any], where: str) -> dict[str, Any]:
    values: dict[str, Any] = {}
    vehicle = r.get(data, "vehicle", str, where)
    if vehicle is not None:
        if vehicle not in _VEHICLES:
            raise r.fail(
                f"{where}vehicle",
                f"{vehicle!r}{did_you_mean(vehicle, _VEHICLES)}; the vehicles are: "
                + ", ".join(_VEHICLES),
                where[:-1] or None,
            )
        values["vehicle"] = vehicle
    for key in ("world", "config", "state_dir"):
        if key in data and (where or key != "state_dir"):
            p = r.path(data, key, where)
            if key != "state_dir" and p is not None and not p.is_file():
                raise r.fail(f"{where}{key}", f"{p}: no such file", where[:-1] or None)
            values[key] = p
    return values


def _overrides(r: _Reader, table: object, platforms: list[int]) -> dict[int, dict[str, Any]]:
    if not isinstance(table, dict):
        raise r.fail("platform", 'expected tables such as [platform.3] or [platform."4-6"]')
    out: dict[int, dict[str, Any]] = {}
    for name, data in table.items():
        where = f"platform.{name}"
        try:
            ids = _ids(name)
        except ValueError as exc:
            raise r.fail("platform", f"[{where}]: {exc}") from None
        if not isinstance(data, dict):
            raise r.fail(where, "expected a table of overrides")
        r.unknown(data, _PER_PLATFORM, where)
        strays = sorted(set(ids) - set(platforms))
        if strays:
            raise r.fail("platform", f"[{where}]: {strays} not among the platforms launched")
        values = _plan_values(r, data, f"{where}.")
        for pid in ids:
            if pid in out:
                raise r.fail("platform", f"[{where}]: platform {pid} has overrides already")
            out[pid] = values
    return out
