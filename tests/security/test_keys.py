"""Key material: created with safe permissions, never overwritten unasked, loaded with errors
that name the file and say what to do."""

from __future__ import annotations

import os
import stat
from collections.abc import Iterator
from pathlib import Path

import pytest
from cryptography.hazmat.primitives import serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey

from actorswarm.security import (
    KeyFileError,
    KeyPaths,
    KeysExistError,
    default_key_dir,
    fingerprint,
    init_keys,
    load_keys,
    public_key_fingerprint,
)

pytestmark = pytest.mark.skipif(os.name != "posix", reason="file modes are POSIX")


def _mode(path: Path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


@pytest.fixture
def umask() -> Iterator[None]:
    """Restore the process umask after a test that changes it."""
    old = os.umask(0o022)
    os.umask(old)
    yield
    os.umask(old)


@pytest.fixture
def keydir(tmp_path: Path) -> Path:
    directory = tmp_path / "keys"
    init_keys(directory)
    return directory


# --- init ---------------------------------------------------------------------------------


@pytest.mark.parametrize("mask", [0o000, 0o022, 0o077])
@pytest.mark.usefixtures("umask")
def test_init_creates_three_files_with_safe_modes_whatever_the_umask(
    tmp_path: Path, mask: int
) -> None:
    os.umask(mask)
    paths = init_keys(tmp_path / "a" / "keys")
    assert paths == KeyPaths.in_dir(tmp_path / "a" / "keys")
    assert _mode(paths.directory) == 0o700
    assert _mode(paths.swarm_key) == 0o600
    assert _mode(paths.gs_private) == 0o600
    assert _mode(paths.gs_public) == 0o644
    assert sorted(p.name for p in paths.directory.iterdir()) == [
        "ground_station.key",
        "ground_station.pub",
        "swarm.key",
    ], "no temporary file is left behind"


def test_init_writes_what_load_reads(keydir: Path) -> None:
    text = (keydir / "swarm.key").read_text()
    assert len(text.strip()) == 64 and text.endswith("\n")
    assert bytes.fromhex(text) == load_keys(keydir).swarm_key
    assert (keydir / "ground_station.key").read_bytes().startswith(b"-----BEGIN PRIVATE KEY")
    assert (keydir / "ground_station.pub").read_bytes().startswith(b"-----BEGIN PUBLIC KEY")


def test_two_inits_make_different_keys(tmp_path: Path) -> None:
    a, b = (
        load_keys(init_keys(tmp_path / "a").directory),
        load_keys(init_keys(tmp_path / "b").directory),
    )
    assert a.swarm_key != b.swarm_key
    assert a.gs_fingerprint != b.gs_fingerprint


def test_init_refuses_to_overwrite_and_names_the_files(keydir: Path) -> None:
    before = {p.name: p.read_bytes() for p in keydir.iterdir()}
    with pytest.raises(KeysExistError) as err:
        init_keys(keydir)
    assert set(err.value.paths) == set(KeyPaths.in_dir(keydir).files)
    assert "swarm.key" in str(err.value) and "--force" in str(err.value)
    assert {p.name: p.read_bytes() for p in keydir.iterdir()} == before


def test_init_refuses_when_only_one_file_exists(tmp_path: Path) -> None:
    directory = tmp_path / "keys"
    directory.mkdir()
    (directory / "ground_station.pub").write_text("mine")
    with pytest.raises(KeysExistError) as err:
        init_keys(directory)
    assert err.value.paths == [directory / "ground_station.pub"]
    assert sorted(p.name for p in directory.iterdir()) == ["ground_station.pub"]


def test_force_replaces_every_file_with_safe_modes(keydir: Path) -> None:
    old = load_keys(keydir, need_private=True)
    os.chmod(keydir / "swarm.key", 0o644)  # a lax old file: the new one is private anyway
    init_keys(keydir, force=True)
    new = load_keys(keydir, need_private=True)
    assert new.swarm_key != old.swarm_key and new.gs_fingerprint != old.gs_fingerprint
    assert _mode(keydir / "swarm.key") == 0o600
    assert _mode(keydir / "ground_station.key") == 0o600
    assert _mode(keydir / "ground_station.pub") == 0o644
    assert len(list(keydir.iterdir())) == 3


def test_init_keeps_the_mode_of_an_existing_directory(tmp_path: Path) -> None:
    os.chmod(tmp_path, 0o755)
    init_keys(tmp_path)
    assert _mode(tmp_path) == 0o755
    assert _mode(tmp_path / "swarm.key") == 0o600


def test_init_into_a_file_is_an_error(tmp_path: Path) -> None:
    target = tmp_path / "file"
    target.write_text("x")
    with pytest.raises(KeyFileError, match="not a directory"):
        init_keys(target)


def test_default_key_dir_follows_xdg(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "xdg"))
    assert default_key_dir() == tmp_path / "xdg" / "actorswarm" / "keys"
    monkeypatch.delenv("XDG_CONFIG_HOME")
    assert default_key_dir() == tmp_path / "home" / ".config" / "actorswarm" / "keys"
    monkeypatch.setenv("XDG_CONFIG_HOME", "relative/dir")  # ignored, as the spec says
    assert default_key_dir() == tmp_path / "home" / ".config" / "actorswarm" / "keys"


# --- load ---------------------------------------------------------------------------------


def test_load_without_private_never_reads_it(keydir: Path) -> None:
    (keydir / "ground_station.key").write_text("garbage")
    os.chmod(keydir / "ground_station.key", 0o666)
    keys = load_keys(keydir)
    assert keys.gs_private is None
    assert len(keys.swarm_key) == 32


def test_load_with_private_matches_the_public_key(keydir: Path) -> None:
    keys = load_keys(keydir, need_private=True)
    assert keys.gs_private is not None
    assert public_key_fingerprint(keys.gs_private.public_key()) == keys.gs_fingerprint


def test_fingerprints_are_16_hex_of_sha256_and_repr_hides_secrets(keydir: Path) -> None:
    keys = load_keys(keydir, need_private=True)
    assert keys.swarm_fingerprint == fingerprint(keys.swarm_key)
    assert len(keys.swarm_fingerprint) == 16
    int(keys.swarm_fingerprint, 16)
    assert fingerprint(b"") == "e3b0c44298fc1c14"
    text = repr(keys)
    assert keys.swarm_fingerprint in text and keys.gs_fingerprint in text
    assert keys.swarm_key.hex() not in text and "PRIVATE" not in text


def _ec_pem(private: bool) -> bytes:
    key = ec.generate_private_key(ec.SECP256R1())
    if private:
        return key.private_bytes(
            serialization.Encoding.PEM,
            serialization.PrivateFormat.PKCS8,
            serialization.NoEncryption(),
        )
    return key.public_key().public_bytes(
        serialization.Encoding.PEM, serialization.PublicFormat.SubjectPublicKeyInfo
    )


def _encrypted_private() -> bytes:
    return Ed25519PrivateKey.generate().private_bytes(
        serialization.Encoding.PEM,
        serialization.PrivateFormat.PKCS8,
        serialization.BestAvailableEncryption(b"passphrase"),
    )


def _other_private() -> bytes:
    return Ed25519PrivateKey.generate().private_bytes(
        serialization.Encoding.PEM,
        serialization.PrivateFormat.PKCS8,
        serialization.NoEncryption(),
    )


PEM_JUNK = b"-----BEGIN PUBLIC KEY-----\nnot base64 at all\n-----END PUBLIC KEY-----\n"

# (file, new content or None to delete, expected words in the problem)
BROKEN: list[tuple[str, bytes | None, str]] = [
    ("swarm.key", None, "missing"),
    ("ground_station.pub", None, "missing"),
    ("ground_station.key", None, "missing"),
    ("swarm.key", b"ab" * 16 + b"\n", "holds 16 bytes"),
    ("swarm.key", b"ab" * 33, "holds 33 bytes"),
    ("swarm.key", b"", "holds 0 bytes"),
    ("swarm.key", b"zz" * 32, "not hex"),
    ("swarm.key", b"abc", "not hex"),
    ("swarm.key", "é".encode() * 32, "not hex"),
    ("swarm.key", b"0" * 70_000, "larger than"),
    ("ground_station.pub", b"hello", "not a PEM file"),
    ("ground_station.pub", PEM_JUNK, "not a valid PEM public key"),
    ("ground_station.pub", _ec_pem(private=False), "not an Ed25519 public key"),
    ("ground_station.key", b"hello", "not a PEM file"),
    ("ground_station.key", PEM_JUNK.replace(b"PUBLIC", b"PRIVATE"), "not a valid PEM private"),
    ("ground_station.key", _ec_pem(private=True), "not an Ed25519 private key"),
    ("ground_station.key", _encrypted_private(), "encrypted"),
    ("ground_station.key", _other_private(), "does not match ground_station.pub"),
]


@pytest.mark.parametrize(("name", "content", "problem"), BROKEN)
def test_every_load_error_names_the_file_and_the_problem(
    keydir: Path, name: str, content: bytes | None, problem: str
) -> None:
    path = keydir / name
    if content is None:
        path.unlink()
    else:
        path.write_bytes(content)  # write_bytes keeps the file's mode (0600 for secrets)
    with pytest.raises(KeyFileError) as err:
        load_keys(keydir, need_private=True)
    assert err.value.path == path
    assert problem in err.value.problem, err.value.problem
    assert str(path) in str(err.value)
    assert isinstance(err.value, ValueError) and not isinstance(err.value, KeyError)


@pytest.mark.parametrize("name", ["swarm.key", "ground_station.key"])
@pytest.mark.parametrize("mode", [0o640, 0o604, 0o620, 0o660, 0o644])
def test_a_secret_others_may_access_is_refused_with_the_chmod_to_run(
    keydir: Path, name: str, mode: int
) -> None:
    path = keydir / name
    os.chmod(path, mode)
    with pytest.raises(KeyFileError) as err:
        load_keys(keydir, need_private=True)
    assert err.value.path == path
    assert f"chmod 600 {path}" in str(err.value)
    assert f"{mode:04o}" in str(err.value)
    os.chmod(path, 0o600)
    load_keys(keydir, need_private=True)


def test_public_key_may_be_world_readable(keydir: Path) -> None:
    os.chmod(keydir / "ground_station.pub", 0o644)
    load_keys(keydir)


def test_missing_directory_says_how_to_create_keys(tmp_path: Path) -> None:
    with pytest.raises(KeyFileError) as err:
        load_keys(tmp_path / "nowhere")
    assert err.value.path == tmp_path / "nowhere"
    assert "actorswarm keys init" in str(err.value)


def test_missing_file_says_how_to_create_keys(keydir: Path) -> None:
    (keydir / "swarm.key").unlink()
    with pytest.raises(KeyFileError, match="actorswarm keys init"):
        load_keys(keydir)
    with pytest.raises(KeyFileError) as err:
        load_keys(keydir)
    assert f"`actorswarm keys init --dir {keydir}`, or copy it here" in str(err.value)


def test_the_default_directory_needs_no_dir_in_the_hint(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path))
    with pytest.raises(KeyFileError) as err:
        load_keys(tmp_path / "actorswarm" / "keys")
    assert str(err.value).endswith("no such key directory; create keys with `actorswarm keys init`")


def test_a_directory_in_place_of_a_key_file_is_refused(keydir: Path) -> None:
    (keydir / "ground_station.pub").unlink()
    (keydir / "ground_station.pub").mkdir()
    with pytest.raises(KeyFileError, match="not a regular file"):
        load_keys(keydir)
