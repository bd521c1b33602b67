"""A script checked in a child process (what a daemon does, ``actorswarm.dsl.isolated``):
the same model or the same first diagnostic as the checker in this process, mappings
read-only as the checker makes them, a child that fails or answers garbage refuses the
script saying why, and the calling process never imports the checker."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from types import MappingProxyType

import pytest

from actorswarm.dsl import isolated
from actorswarm.dsl.isolated import ScriptRefused, check_in_process, check_isolated

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.parametrize("name", ["branch_merge.xml", "formation_30.xml"])
def test_the_child_gives_the_model_the_checker_gives_here(name: str) -> None:
    text = (EXAMPLES / name).read_text()
    here = check_in_process(text, name)
    there = check_isolated(text, name)
    assert there == here
    assert type(there.transitions) is MappingProxyType
    assert all(type(a.buses) is MappingProxyType for a in there.actors)


def test_a_refused_script_is_refused_with_the_checkers_first_diagnostic() -> None:
    text = (EXAMPLES / "branch_merge.xml").read_text().replace('sysNum="', 'sysNum="x', 1)
    with pytest.raises(ScriptRefused) as here:
        check_in_process(text, "bad.xml")
    with pytest.raises(ScriptRefused) as there:
        check_isolated(text, "bad.xml")
    assert str(there.value) == str(here.value)
    assert str(there.value).startswith("bad.xml:"), str(there.value)


def test_a_child_that_fails_hangs_or_answers_garbage_refuses_the_script(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    failing = tmp_path / "failing"
    failing.write_text("#!/bin/sh\necho 'checker exploded' >&2\nexit 3\n")
    garbage = tmp_path / "garbage"
    garbage.write_text("#!/bin/sh\ncat > /dev/null\nprintf 'not msgpack at all'\n")
    for exe in (failing, garbage):
        exe.chmod(0o755)
    text = (EXAMPLES / "branch_merge.xml").read_text()
    monkeypatch.setattr(isolated.sys, "executable", str(failing))
    with pytest.raises(ScriptRefused, match=r"failed \(exit 3\): checker exploded"):
        check_isolated(text, "s.xml")
    monkeypatch.setattr(isolated.sys, "executable", str(garbage))
    with pytest.raises(ScriptRefused, match="unreadable"):
        check_isolated(text, "s.xml")
    hanging = tmp_path / "hanging"
    hanging.write_text("#!/bin/sh\nexec sleep 30\n")
    hanging.chmod(0o755)
    monkeypatch.setattr(isolated.sys, "executable", str(hanging))
    with pytest.raises(ScriptRefused, match=r"did not answer in 0\.5 s"):
        check_isolated(text, "s.xml", timeout=0.5)


def test_with_no_interpreter_to_start_the_script_is_checked_here(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    text = (EXAMPLES / "branch_merge.xml").read_text()
    monkeypatch.setattr(isolated.sys, "executable", str(tmp_path / "missing"))
    assert check_isolated(text, "s.xml") == check_in_process(text, "s.xml")
    with pytest.raises(ScriptRefused, match=r"^bad\.xml:"):
        check_isolated(text.replace('sysNum="', 'sysNum="x', 1), "bad.xml")


def test_the_calling_process_never_imports_the_checker() -> None:
    code = (
        "import json, sys\n"
        "import actorswarm.daemon.run\n"
        "from actorswarm.dsl.isolated import check_isolated\n"
        f"model = check_isolated(open({str(EXAMPLES / 'branch_merge.xml')!r}).read(), 'b')\n"
        "print(json.dumps([len(model.actors), sorted(m for m in sys.modules\n"
        "    if m.startswith(('actorswarm.dsl.checker', 'actorswarm.dsl.rules',\n"
        "                     'actorswarm.dsl.builder', 'xml.parsers')))]))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True
    )
    actors, imported = json.loads(out.stdout.strip().splitlines()[-1])
    assert actors > 0 and imported == []
