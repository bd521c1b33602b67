"""Key material of a swarm: creating it with safe permissions, loading it with clear errors.

Theory of operation
-------------------
A key directory holds three files:

``swarm.key``
    32 random bytes as hex text: the swarm key every packet's HMAC-SHA256 tag is made
    with. Secret; every platform and the ground station hold it.
``ground_station.key``
    The ground station's Ed25519 private key (PEM, PKCS#8, unencrypted). Secret; it signs
    operator commands and belongs on the ground station only.
``ground_station.pub``
    The matching public key (PEM). Not secret; platforms verify operator commands with it.

A platform needs ``swarm.key`` and ``ground_station.pub``; the ground station needs all
three. :func:`init_keys` creates the directory private to its owner (0700) and writes the
secrets with mode 0600 from the moment they exist (``os.open`` with the mode; a forced
replacement goes through a private temporary file and an atomic rename), so a secret is never
readable by anyone else, not even briefly. :func:`load_keys` refuses a secret file that group
or others may access, and says which ``chmod`` fixes it.

Every problem with a key file is a :class:`KeyFileError` naming the file and what is wrong
with it; existing keys are never overwritten unless asked (:class:`KeysExistError`).

A platform loads its keys without the ``cryptography`` package: the public key is read by
:class:`~actorswarm.security.ed25519.PublicKey`, which verifies with libsodium (PyNaCl), and
nothing here loads OpenSSL. ``cryptography`` is imported only to make keys (:func:`init_keys`)
and to load the private key (``need_private=True``, the ground station, which signs).
"""

from __future__ import annotations

import os
import stat
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Final

from actorswarm.core.digest import sha256_hex
from actorswarm.security.ed25519 import KeyFormatError, PublicKey

if TYPE_CHECKING:
    from cryptography.hazmat.primitives.asymmetric.ed25519 import (
        Ed25519PrivateKey,
        Ed25519PublicKey,
    )

SWARM_KEY_FILE: Final = "swarm.key"
GS_PRIVATE_FILE: Final = "ground_station.key"
GS_PUBLIC_FILE: Final = "ground_station.pub"
#: Bytes of the swarm key (HMAC-SHA256 key).
SWARM_KEY_BYTES: Final = 32
_SECRET_MODE: Final = 0o600
_PUBLIC_MODE: Final = 0o644
_DIR_MODE: Final = 0o700
_MAX_FILE_BYTES: Final = 64 * 1024


def init_hint(directory: Path) -> str:
    """The command that creates the key files of ``directory`` (``--dir`` only when it is
    not the default one)."""
    where = "" if directory == default_key_dir() else f" --dir {directory}"
    return f"create keys with `actorswarm keys init{where}`"


class KeyFileError(ValueError):
    """A key file (or key directory) that cannot be used: ``path`` and what is wrong."""

    def __init__(self, path: Path, problem: str) -> None:
        super().__init__(f"{path}: {problem}")
        self.path = path
        self.problem = problem


class KeysExistError(FileExistsError):
    """:func:`init_keys` would overwrite key files (``paths``) and was not forced."""

    def __init__(self, paths: list[Path]) -> None:
        names = ", ".join(str(p) for p in paths)
        super().__init__(
            f"refusing to overwrite existing key files: {names}. Replace them with --force "
            "(force=True); every platform then needs the new swarm.key and ground_station.pub"
        )
        self.paths = paths


@dataclass(frozen=True, slots=True)
class KeyPaths:
    """Where the key files of one key directory are."""

    directory: Path
    swarm_key: Path
    gs_private: Path
    gs_public: Path

    @classmethod
    def in_dir(cls, directory: str | os.PathLike[str]) -> KeyPaths:
        d = Path(directory).expanduser()
        return cls(d, d / SWARM_KEY_FILE, d / GS_PRIVATE_FILE, d / GS_PUBLIC_FILE)

    @property
    def files(self) -> tuple[Path, Path, Path]:
        return (self.swarm_key, self.gs_private, self.gs_public)


@dataclass(frozen=True, slots=True, repr=False)
class Keys:
    """Loaded key material. The secrets never appear in ``repr`` (fingerprints do)."""

    swarm_key: bytes
    gs_public: PublicKey
    paths: KeyPaths
    #: Only loaded when asked for (``load_keys(..., need_private=True)``): a platform never
    #: reads the operator's signing key, even when the file happens to be there.
    gs_private: Ed25519PrivateKey | None = None

    @property
    def swarm_fingerprint(self) -> str:
        return fingerprint(self.swarm_key)

    @property
    def gs_fingerprint(self) -> str:
        return self.gs_public.fingerprint

    def __repr__(self) -> str:
        private = "with" if self.gs_private is not None else "without"
        return (
            f"Keys({self.paths.directory}: swarm key {self.swarm_fingerprint}, ground station "
            f"{self.gs_fingerprint}, {private} the ground station's private key)"
        )


def fingerprint(data: bytes) -> str:
    """The first 16 hex digits of SHA-256 of ``data``: safe to show, to compare keys by."""
    return sha256_hex(data)[:16]


def public_key_fingerprint(key: PublicKey | Ed25519PublicKey) -> str:
    """Fingerprint of an Ed25519 public key (of its 32 raw bytes, not of its PEM text), the
    same for the key as :class:`~actorswarm.security.ed25519.PublicKey` and as
    ``cryptography`` hold it."""
    return fingerprint(PublicKey.of(key).raw)


def default_key_dir() -> Path:
    """``$XDG_CONFIG_HOME/actorswarm/keys``, or ``~/.config/actorswarm/keys``.

    As the XDG base-directory specification says, a relative ``XDG_CONFIG_HOME`` is ignored.
    """
    xdg = os.environ.get("XDG_CONFIG_HOME", "")
    base = Path(xdg) if xdg and Path(xdg).is_absolute() else Path.home() / ".config"
    return base / "actorswarm" / "keys"


# --- creating ------------------------------------------------------------------------------


def init_keys(directory: str | os.PathLike[str], *, force: bool = False) -> KeyPaths:
    """Create a new swarm key and ground-station key pair in ``directory``.

    The directory is created with mode 0700 when it does not exist (an existing directory
    keeps its mode), the secrets with 0600, the public key with 0644. Raises
    :class:`KeysExistError` when any of the three files exists, unless ``force``; then all
    three are replaced, each atomically.
    """
    paths = KeyPaths.in_dir(directory)
    existing = [p for p in paths.files if p.exists() or p.is_symlink()]
    if existing and not force:
        raise KeysExistError(existing)
    if not paths.directory.exists():
        paths.directory.mkdir(parents=True, mode=_DIR_MODE)
        os.chmod(paths.directory, _DIR_MODE)  # mkdir's mode is filtered by the umask
    elif not paths.directory.is_dir():
        raise KeyFileError(paths.directory, "is not a directory")

    from cryptography.hazmat.primitives import serialization
    from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey

    private = Ed25519PrivateKey.generate()
    private_pem = private.private_bytes(
        serialization.Encoding.PEM,
        serialization.PrivateFormat.PKCS8,
        serialization.NoEncryption(),
    )
    public_pem = private.public_key().public_bytes(
        serialization.Encoding.PEM, serialization.PublicFormat.SubjectPublicKeyInfo
    )
    swarm_text = (os.urandom(SWARM_KEY_BYTES).hex() + "\n").encode("ascii")

    _write(paths.swarm_key, swarm_text, _SECRET_MODE, replace=force)
    _write(paths.gs_private, private_pem, _SECRET_MODE, replace=force)
    _write(paths.gs_public, public_pem, _PUBLIC_MODE, replace=force)
    return paths


def _write(path: Path, data: bytes, mode: int, *, replace: bool) -> None:
    """Write ``data`` to a new file that has ``mode`` from its creation on.

    Without ``replace`` the file must not exist (``O_EXCL``: a file that appeared meanwhile
    is not overwritten); with it, a private temporary file is renamed over ``path``.
    """
    target = path.with_name(f".{path.name}.{os.urandom(4).hex()}.tmp") if replace else path
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0)
    try:
        fd = os.open(target, flags, mode)
    except FileExistsError:
        raise KeysExistError([path]) from None
    try:
        with os.fdopen(fd, "wb") as f:
            if hasattr(os, "fchmod"):
                os.fchmod(f.fileno(), mode)  # the umask may have removed bits of a public file
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        if replace:
            os.replace(target, path)
    except BaseException:
        target.unlink(missing_ok=True)
        raise


# --- loading -------------------------------------------------------------------------------


def load_keys(directory: str | os.PathLike[str], *, need_private: bool = False) -> Keys:
    """Load the swarm key and the ground station's public key from ``directory``.

    With ``need_private`` (the ground station) the private key is loaded too and must match
    the public key; without it the private key file is never read. Every problem is a
    :class:`KeyFileError` naming the file.
    """
    paths = KeyPaths.in_dir(directory)
    if not paths.directory.is_dir():
        raise KeyFileError(paths.directory, f"no such key directory; {init_hint(paths.directory)}")
    swarm_key = _load_swarm_key(paths.swarm_key)
    public = _load_public(paths.gs_public)
    private = _load_private(paths.gs_private) if need_private else None
    if private is not None and public_key_fingerprint(private.public_key()) != public.fingerprint:
        raise KeyFileError(
            paths.gs_private,
            f"does not match {paths.gs_public.name}: both must come from the same `keys init`",
        )
    return Keys(swarm_key=swarm_key, gs_public=public, gs_private=private, paths=paths)


def _read(path: Path, *, secret: bool) -> bytes:
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise KeyFileError(path, f"missing; {init_hint(path.parent)}, or copy it here") from None
    except OSError as exc:
        raise KeyFileError(path, f"cannot be read: {exc.strerror}") from None
    if not stat.S_ISREG(st.st_mode):
        raise KeyFileError(path, "is not a regular file")
    if secret and os.name == "posix" and st.st_mode & 0o077:
        raise KeyFileError(
            path,
            f"is accessible by group or others (mode {stat.S_IMODE(st.st_mode):04o}); a secret "
            f"key must be private to its owner: run `chmod 600 {path}`",
        )
    try:
        with path.open("rb") as f:
            data = f.read(_MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise KeyFileError(path, f"cannot be read: {exc.strerror}") from None
    if len(data) > _MAX_FILE_BYTES:
        raise KeyFileError(path, f"is larger than {_MAX_FILE_BYTES} bytes: not a key file")
    return data


def _load_swarm_key(path: Path) -> bytes:
    data = _read(path, secret=True)
    expected = f"expected {SWARM_KEY_BYTES * 2} hexadecimal digits"
    try:
        key = bytes.fromhex(data.decode("ascii").strip())
    except (UnicodeDecodeError, ValueError):
        raise KeyFileError(path, f"is not hex text ({expected})") from None
    if len(key) != SWARM_KEY_BYTES:
        raise KeyFileError(path, f"holds {len(key)} bytes, {expected} ({SWARM_KEY_BYTES} bytes)")
    return key


def _check_pem(path: Path, data: bytes) -> None:
    if not data.lstrip().startswith(b"-----BEGIN "):
        raise KeyFileError(path, "is not a PEM file (no '-----BEGIN' line)")


def _load_public(path: Path) -> PublicKey:
    data = _read(path, secret=False)
    _check_pem(path, data)
    try:
        return PublicKey.from_pem(data)
    except KeyFormatError as exc:
        raise KeyFileError(path, str(exc)) from None


def _load_private(path: Path) -> Ed25519PrivateKey:
    from cryptography.exceptions import UnsupportedAlgorithm
    from cryptography.hazmat.primitives import serialization
    from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey

    data = _read(path, secret=True)
    _check_pem(path, data)
    try:
        key = serialization.load_pem_private_key(data, password=None)
    except TypeError:
        raise KeyFileError(
            path, "is encrypted with a passphrase; actorswarm needs an unencrypted PKCS#8 key"
        ) from None
    except (ValueError, UnsupportedAlgorithm) as exc:
        raise KeyFileError(path, f"is not a valid PEM private key ({exc})") from None
    if not isinstance(key, Ed25519PrivateKey):
        raise KeyFileError(path, f"holds a {type(key).__name__}, not an Ed25519 private key")
    return key


__all__ = [
    "GS_PRIVATE_FILE",
    "GS_PUBLIC_FILE",
    "SWARM_KEY_BYTES",
    "SWARM_KEY_FILE",
    "KeyFileError",
    "KeyPaths",
    "Keys",
    "KeysExistError",
    "default_key_dir",
    "fingerprint",
    "init_keys",
    "load_keys",
    "public_key_fingerprint",
]
