"""The election block of docs/collective-core.md is generated from the rule tables."""

from __future__ import annotations

import difflib
from pathlib import Path

import pytest

from actorswarm.core.election import CLAIM_RULES, HEARTBEAT_RULES
from actorswarm.docgen.election import BEGIN, COMMAND, END, main, render, splice

DOC = Path(__file__).resolve().parents[1] / "docs" / "collective-core.md"


def test_doc_block_is_generated_from_the_rules() -> None:
    text = DOC.read_text(encoding="utf-8")
    wanted = splice(text, render())
    if wanted != text:
        diff = "".join(
            difflib.unified_diff(
                text.splitlines(keepends=True), wanted.splitlines(keepends=True), "doc", "rules"
            )
        )
        pytest.fail(
            f"{DOC.name}: the election block differs from the election rules; "
            f"regenerate it with:\n    {COMMAND}\n\n{diff}"
        )


def test_every_rule_is_a_table_row() -> None:
    block = render()
    for rule in (*HEARTBEAT_RULES, *CLAIM_RULES):
        assert f"| {rule.name} | " in block


def test_diagram_shows_the_transitions_the_rules_imply() -> None:
    block = render()
    for edge in (
        "master --> masterless : STEP_DOWN (H1)",
        "master --> master : RECLAIM (H2, H3, H3b)",
        "follower --> masterless : DEMOTED (H4)",
        "masterless --> follower : FOLLOW (H6, H7)",
        "follower --> follower : FOLLOW (H6)",
        "masterless --> master : claim (C4)",
        "follower --> master : claim (C5)",
    ):
        assert f"    {edge}\n" in block
    assert "IGNORE (" not in block  # ignoring changes no role


STALE = f"# Doc\n\nbefore\n\n{BEGIN}\nold text\n{END}\n\nafter\n"


def test_check_fails_with_a_diff_then_write_fixes_only_the_block(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    doc = tmp_path / "doc.md"
    doc.write_text(STALE, encoding="utf-8")
    assert main(["--check", "--doc", str(doc)]) == 1
    out, err = capsys.readouterr()
    assert "-old text" in out and "+| H1 | master |" in out
    assert COMMAND in err
    assert doc.read_text(encoding="utf-8") == STALE  # --check writes nothing

    assert main(["--write", "--doc", str(doc)]) == 0
    text = doc.read_text(encoding="utf-8")
    assert text == f"# Doc\n\nbefore\n\n{BEGIN}\n{render()}{END}\n\nafter\n"
    assert main(["--check", "--doc", str(doc)]) == 0


@pytest.mark.parametrize(
    "text", ["no markers\n", f"{END}\n{BEGIN}\n", f"{BEGIN}\n{END}\n{BEGIN}\n{END}\n"]
)
def test_markers_must_be_one_pair_in_order(tmp_path: Path, text: str) -> None:
    doc = tmp_path / "doc.md"
    doc.write_text(text, encoding="utf-8")
    assert main(["--check", "--doc", str(doc)]) == 2
    assert main(["--write", "--doc", str(doc)]) == 2
    assert doc.read_text(encoding="utf-8") == text
