"""Security: authenticated, replay-proof packets between the core and every transport.

:mod:`.keys` creates and loads a swarm's key material (a shared swarm key, the ground
station's Ed25519 key pair); :mod:`.ed25519` verifies the ground station's signatures
without the ``cryptography`` package, which a platform therefore never imports;
:class:`PacketGuard` seals outgoing packets and checks incoming ones (docs/design.md §2:
security sits between the core and the transport). The guard's module documentation states
the threat model.
"""

from actorswarm.security.guard import DEFAULT_WINDOW, REASONS, PacketGuard, Role
from actorswarm.security.keys import (
    KeyFileError,
    KeyPaths,
    Keys,
    KeysExistError,
    default_key_dir,
    fingerprint,
    init_keys,
    load_keys,
    public_key_fingerprint,
)

__all__ = [
    "DEFAULT_WINDOW",
    "REASONS",
    "KeyFileError",
    "KeyPaths",
    "Keys",
    "KeysExistError",
    "PacketGuard",
    "Role",
    "default_key_dir",
    "fingerprint",
    "init_keys",
    "load_keys",
    "public_key_fingerprint",
]
