"""The architecture pictures of docs/design.md are drawn from the code and kept current."""

from __future__ import annotations

from pathlib import Path

from actorswarm.docgen import architecture
from actorswarm.docgen.block import splice

DOC = Path(__file__).resolve().parents[1] / "docs" / "design.md"


def test_design_doc_pictures_match_the_code() -> None:
    text = DOC.read_text(encoding="utf-8")
    wanted = splice(text, architecture.render(), architecture.BEGIN, architecture.END)
    assert wanted == text, f"{DOC.name} is stale; regenerate with: {architecture.COMMAND}"


def _package(root: Path, name: str, files: dict[str, str]) -> None:
    folder = root / name
    folder.mkdir(parents=True)
    for file, text in files.items():
        (folder / file).write_text(text, encoding="utf-8")


def test_imports_are_read_at_run_time_only_and_implied_arrows_left_out(tmp_path: Path) -> None:
    root = tmp_path / "pkg"
    _package(root, "low", {"__init__.py": ""})
    _package(root, "mid", {"__init__.py": "", "a.py": "from pkg.low import x\n"})
    _package(
        root,
        "top",
        {
            "__init__.py": "",
            "b.py": (
                "from typing import TYPE_CHECKING\n"
                "import pkg.mid.a\n"
                "from pkg.low import y\n"
                "if TYPE_CHECKING:\n"
                "    from pkg.side import z\n"
                "def f():\n"
                "    import pkg.lazy\n"
            ),
        },
    )
    graph = architecture.package_imports(root)
    assert graph["top"] == {"mid", "low", "lazy"}  # lazy imports count, TYPE_CHECKING not
    assert graph["mid"] == {"low"}
    assert architecture.reduced(graph)["top"] == {"mid", "lazy"}  # top → low is implied


def test_a_cycle_keeps_its_arrows() -> None:
    graph = {"a": {"b", "c"}, "b": {"a"}, "c": set()}
    assert architecture.reduced(graph) == {"a": {"b", "c"}, "b": {"a"}, "c": set()}


def test_node_picture_names_its_class_chain_and_parts() -> None:
    block = architecture.render()
    assert "class Node[" in block
    assert "*-- Reliable : reliable" in block
    assert "*-- Collector : _out" in block


def test_tree_lists_every_module_and_part_folder_with_a_plain_summary(tmp_path: Path) -> None:
    _package(tmp_path, "core", {"__init__.py": '"""The core."""\n', "wire.py": '"""Packets."""\n'})
    _package(
        tmp_path / "core",
        "part",
        {
            "__init__.py": '"""One part: what it does.\n\nMore text."""\n',
            "a.py": '"""Uses :class:`~pkg.core.part.a.Thing` and ``x``. Second sentence."""\n',
            "b.py": '"""' + "word " * 30 + '"""\n',
        },
    )
    (tmp_path / "core" / "notes").mkdir()  # no __init__.py: not a part
    lines = architecture.tree_listing("core", tmp_path)
    assert lines[0] == "```text" and lines[-1] == "```"
    assert lines[1] == "core/  The core"
    assert lines[2].split() == ["wire.py", "1", "lines", "Packets"]
    assert lines[3] == "  part/  One part: what it does"
    assert lines[4].endswith("Uses Thing and x")  # roles and literals read plain, one sentence
    assert lines[5].endswith(" …") and len(lines[5].split("lines  ", 1)[1]) <= 74
    assert len(lines) == 7  # notes/ is left out


def test_every_door_of_an_endpoint_shows(tmp_path: Path) -> None:
    """A class with a second way in (bytes to a ``receive``) or out (``drain_outgoing``)
    shows it; a protocol and a class that takes no packets are left out."""
    root = tmp_path / "pkg"
    _package(
        root,
        "core",
        {
            "__init__.py": "",
            "node.py": (
                "from typing import Protocol\n"
                "class Node:\n"
                "    def receive(self, data: bytes, now: float) -> None: ...\n"
                "    def receive_packet(self, packet: Packet, now: float) -> None: ...\n"
                "    def deploy(self, script: bytes) -> str: ...\n"
                "    def ready(self) -> Ready: ...\n"
                "    def drain_outgoing(self) -> list[Outgoing]: ...\n"
                "    def _emit(self, packet: Packet) -> None: ...\n"
                "class Shape(Protocol):\n"
                "    def receive_packet(self, packet: Packet, now: float) -> None: ...\n"
                "class Other:\n"
                "    def ready(self) -> bool: ...\n"
            ),
        },
    )
    assert architecture.endpoint_ways(root) == {
        "core.node:Node": (["receive", "receive_packet"], ["ready", "drain_outgoing"])
    }


def test_the_packets_way_in_and_out_is_read_from_the_pipeline() -> None:
    from actorswarm.security.pipeline import Pipeline

    calls = architecture.method_calls(Pipeline)
    assert calls["receive"] == [("guard", "check"), ("endpoint", "receive_packet")]
    assert calls["flush"] == [("endpoint", "ready"), ("self", "send")], "ready() runs first"
    assert calls["send"] == [("guard", "seal"), ("transport", "send")]
    block = architecture.render()
    for endpoint in ("Node (core.node.coordinator)", "GroundStation (ground.station)"):
        assert f"{endpoint}<br/>in: receive_packet<br/>out: ready" in block
