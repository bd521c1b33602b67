"""Backups are written atomically and read back whole or not at all."""

from __future__ import annotations

from pathlib import Path

from actorswarm.runtime.storage import FileBackupStore, MemoryBackupStore


def test_file_store_round_trip_and_generations(tmp_path: Path) -> None:
    store = FileBackupStore(tmp_path / "backups", keep=3)
    assert store.latest() is None
    assert [store.write(f"b{i}".encode()) for i in range(5)] == [1, 2, 3, 4, 5]
    assert store.latest() == b"b4"
    assert len(list((tmp_path / "backups").glob("backup-*.bin"))) == 3, "only the newest kept"


def test_a_crash_mid_write_leaves_the_previous_backup(tmp_path: Path) -> None:
    store = FileBackupStore(tmp_path)
    store.write(b"good")
    # A crash after writing part of the next one: only a temporary file exists.
    (tmp_path / ".backup-000002.tmp").write_bytes(b"ASWB\x00\x00")
    assert store.latest() == b"good"
    # A damaged file under a backup's name (a failing disk) is skipped too.
    (tmp_path / "backup-000003.bin").write_bytes(b"ASWB" + b"\x00" * 8 + b"\x01\x02\x03\x04oops")
    assert store.latest() == b"good"
    assert store.write(b"next") == 4 and store.latest() == b"next"


def test_memory_store_skips_a_damaged_latest() -> None:
    store = MemoryBackupStore()
    store.write(b"one")
    store.write(b"two")
    store.damage_latest()
    assert store.latest() == b"one"


def test_a_restarted_store_numbers_on_and_prunes_what_it_found(tmp_path: Path) -> None:
    first = FileBackupStore(tmp_path, keep=3)
    for i in range(4):
        first.write(f"a{i}".encode())
    (tmp_path / "backup-notes.bin").write_bytes(b"not a backup")  # ignored, left alone
    again = FileBackupStore(tmp_path, keep=3)  # the daemon started again
    assert again.write(b"b0") == 5 and again.write(b"b1") == 6
    names = sorted(p.name for p in tmp_path.glob("backup-*.bin"))
    assert names == ["backup-000004.bin", "backup-000005.bin", "backup-000006.bin",
                     "backup-notes.bin"]  # fmt: skip
    assert again.latest() == b"b1"
