"""Connection settings of the ground-station commands from a profile file or the
environment, so that ``gs status`` needs no ``--swarm … --no-multicast --connect …``.

Every ``gs`` command reads each connection option from, in order: its command line, an
environment variable (:data:`ENVIRONMENT`: ``ACTORSWARM_SWARM``, ``ACTORSWARM_CONNECT``
— endpoints separated by spaces —, ``ACTORSWARM_KEYS``, ``ACTORSWARM_INSECURE`` …), a
profile file (``actorswarm gs --profile FILE …`` or ``ACTORSWARM_PROFILE=FILE``), the
default. A profile is TOML with the same names::

    swarm = "branch-merge"
    connect = ["tcp/127.0.0.1:7501", "tcp/127.0.0.1:7502"]
    multicast = false
    insecure = true            # or: keys = "/home/me/.config/actorswarm/keys"

``actorswarm launch`` writes one for the swarm it starts (:func:`profile_text`). The
options themselves carry the environment variables (``envvar=``,
:mod:`actorswarm.cli.swarm_options`); :func:`apply_profile` puts a profile's settings
where an environment variable is not set, for the command about to parse its options.
"""

from __future__ import annotations

import os
import tomllib
from collections.abc import Callable, MutableMapping
from pathlib import Path
from typing import Any

from actorswarm.suggest import did_you_mean

__all__ = ["ENVIRONMENT", "PROFILE_ENV", "ProfileError", "apply_profile", "profile_text"]

#: The environment variable naming a profile file.
PROFILE_ENV = "ACTORSWARM_PROFILE"

#: Profile key -> (environment variable, kind: str, list, bool or path).
ENVIRONMENT: dict[str, tuple[str, str]] = {
    "swarm": ("ACTORSWARM_SWARM", "str"),
    "connect": ("ACTORSWARM_CONNECT", "list"),
    "listen": ("ACTORSWARM_LISTEN", "list"),
    "multicast": ("ACTORSWARM_MULTICAST", "bool"),
    "broadcast": ("ACTORSWARM_BROADCAST", "str"),
    "group": ("ACTORSWARM_GROUP", "str"),
    "interface": ("ACTORSWARM_INTERFACE", "str"),
    "keys": ("ACTORSWARM_KEYS", "path"),
    "insecure": ("ACTORSWARM_INSECURE", "bool"),
}


class ProfileError(ValueError):
    """A profile file that cannot be read or says something it may not; the message names
    the file and the key."""


def _value(path: Path, key: str, value: Any, kind: str) -> str:
    """The environment variable's text for a profile's ``value``."""
    if kind == "bool" and isinstance(value, bool):
        return "true" if value else "false"
    if kind == "list" and isinstance(value, list) and all(isinstance(v, str) for v in value):
        if any(" " in v for v in value):
            raise ProfileError(f"{path}: {key}: an endpoint holds a space")
        return " ".join(value)
    if kind in ("str", "path") and isinstance(value, str) and value:
        if kind == "path" and not Path(value).is_absolute():
            return str(path.parent / value)  # relative to the profile, as launch files are
        return value
    wanted = {"bool": "true or false", "list": "a list of strings"}.get(kind, "a string")
    raise ProfileError(f"{path}: {key}: expected {wanted}, not {value!r}")


def read_profile(path: Path) -> dict[str, str]:
    """The environment variables a profile sets; ProfileError naming the problem."""
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ProfileError(f"{path}: cannot read the profile: {exc.strerror or exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ProfileError(f"{path}: not TOML: {exc}") from None
    out: dict[str, str] = {}
    for key, value in data.items():
        if key not in ENVIRONMENT:
            raise ProfileError(
                f"{path}: unknown key {key!r}{did_you_mean(key, ENVIRONMENT)}; the keys: "
                + ", ".join(ENVIRONMENT)
            )
        variable, kind = ENVIRONMENT[key]
        out[variable] = _value(path, key, value, kind)
    return out


def apply_profile(
    path: Path | None, environ: MutableMapping[str, str] | None = None
) -> Callable[[], None]:
    """Set the environment variables of the profile ``path`` (None: the one
    :data:`PROFILE_ENV` names, if any) that are not set already; returns what undoes it."""
    env = os.environ if environ is None else environ
    if path is None:
        named = env.get(PROFILE_ENV)
        path = Path(named) if named else None
    if path is None:
        return lambda: None
    added = {k: v for k, v in read_profile(path).items() if k not in env}
    env.update(added)

    def undo() -> None:
        for k in added:
            env.pop(k, None)

    return undo


def profile_text(
    swarm: str, connect: list[str], multicast: bool, keys: Path | None, insecure: bool
) -> str:
    """A profile for these settings (as ``actorswarm launch`` writes it)."""
    lines = [
        "# The ground station's connection settings of a swarm:",
        "#   actorswarm gs --profile THIS-FILE status   (or ACTORSWARM_PROFILE=THIS-FILE)",
        f"swarm = {_toml(swarm)}",
    ]
    if connect:
        lines.append("connect = [" + ", ".join(_toml(c) for c in connect) + "]")
    lines.append(f"multicast = {'true' if multicast else 'false'}")
    if insecure:
        lines.append("insecure = true")
    elif keys is not None:
        lines.append(f"keys = {_toml(str(keys.resolve()))}")
    return "\n".join(lines) + "\n"


def _toml(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'
