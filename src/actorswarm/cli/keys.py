"""``actorswarm keys``: create a swarm's key material and show its fingerprints.

The secrets themselves are never printed: fingerprints (the first 16 hex digits of SHA-256)
are enough to check that two machines hold the same keys.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from actorswarm.security.keys import (
    KeyFileError,
    KeyPaths,
    KeysExistError,
    default_key_dir,
    init_keys,
    load_keys,
)

keys_app = typer.Typer(
    help=(
        "Key material of a swarm: the swarm key that authenticates every packet and the "
        "ground station's signing key pair."
    ),
    no_args_is_help=True,
)

DirOption = Annotated[
    Path | None,
    typer.Option(
        "--dir",
        help="Key directory (default: $XDG_CONFIG_HOME/actorswarm/keys or "
        "~/.config/actorswarm/keys).",
        file_okay=False,
    ),
]


def _fail(message: str) -> typer.Exit:
    typer.echo(f"error: {message}", err=True)
    return typer.Exit(1)


@keys_app.command("init")
def keys_init(
    directory: DirOption = None,
    force: Annotated[
        bool,
        typer.Option(
            "--force", help="Replace existing keys (every platform then needs the new ones)."
        ),
    ] = False,
) -> None:
    """Create a new swarm key and ground-station key pair (secret files mode 0600)."""
    target = directory if directory is not None else default_key_dir()
    try:
        paths = init_keys(target, force=force)
        keys = load_keys(target)
    except KeysExistError as exc:
        names = ", ".join(p.name for p in exc.paths)
        raise _fail(
            f"{target} already holds keys ({names}): keep them, or replace them with "
            "`actorswarm keys init --force` (every platform then needs the new swarm.key and "
            "ground_station.pub)"
        ) from None
    except KeyFileError as exc:
        raise _fail(str(exc)) from None
    typer.echo(f"Created keys in {paths.directory}")
    typer.echo(
        f"  {paths.swarm_key.name:<20} swarm key {keys.swarm_fingerprint}: secret, copy it to "
        "every platform and the ground station"
    )
    typer.echo(
        f"  {paths.gs_private.name:<20} ground-station signing key: secret, keep it on the "
        "ground station only"
    )
    typer.echo(
        f"  {paths.gs_public.name:<20} ground-station public key {keys.gs_fingerprint}: copy "
        "it to every platform"
    )


@keys_app.command("show")
def keys_show(directory: DirOption = None) -> None:
    """Print the fingerprints of the swarm key and the ground station's public key."""
    target = directory if directory is not None else default_key_dir()
    private_present = KeyPaths.in_dir(target).gs_private.exists()
    try:
        keys = load_keys(target, need_private=private_present)
    except KeyFileError as exc:
        raise _fail(str(exc)) from None
    paths = keys.paths
    typer.echo(f"Keys in {paths.directory}")
    typer.echo(f"  swarm key                  {keys.swarm_fingerprint}  ({paths.swarm_key.name})")
    typer.echo(f"  ground-station public key  {keys.gs_fingerprint}  ({paths.gs_public.name})")
    if private_present:
        typer.echo(
            f"  ground-station private key present and matching ({paths.gs_private.name}): "
            "this machine can act as the ground station"
        )
    else:
        typer.echo("  ground-station private key absent: this machine can run platforms only")


__all__ = ["keys_app"]
