"""The entry points of a group, read without importlib.metadata, are exactly the ones
importlib.metadata lists: on this environment, on made-up distributions (a dist-info, an
egg-info, one shadowed by an earlier folder, comments and other groups), and through
importlib.metadata itself when sys.path holds an archive."""

from __future__ import annotations

import importlib
import json
import subprocess
import sys
import zipfile
from importlib import metadata
from pathlib import Path

import pytest

from actorswarm.runtime.entry_points import EntryPoint, entry_points
from actorswarm.runtime.entry_points import _normalize as normalize


def listing(group: str) -> tuple[list[tuple[str, str, str]], list[tuple[str, str, str]]]:
    """(ours, importlib.metadata's): (name, value, normalized distribution name), sorted."""
    ours = sorted((ep.name, ep.value, normalize(ep.dist.name if ep.dist else "")) for ep in
                  entry_points(group=group))  # fmt: skip
    theirs = sorted((ep.name, ep.value, normalize(ep.dist.name if ep.dist else "")) for ep in
                    metadata.entry_points(group=group))  # fmt: skip
    return ours, theirs


@pytest.mark.parametrize("group", ["actorswarm.plugins", "console_scripts", "pytest11", "none"])
def test_this_environment_lists_as_importlib_metadata_does(group: str) -> None:
    ours, theirs = listing(group)
    assert ours == theirs
    if group == "actorswarm.plugins":
        assert ("core.idle", "actorswarm.runtime.builtin:Idle", "actorswarm") in ours


def _dist(folder: Path, info: str, text: str) -> None:
    (folder / info).mkdir(parents=True)
    (folder / info / "entry_points.txt").write_text(text)
    name = info.split("-", maxsplit=1)[0].split(".", maxsplit=1)[0].replace("_", "-")
    (folder / info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 2.0\n")


def test_made_up_distributions_list_as_importlib_metadata_lists_them(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    first, second = tmp_path / "first", tmp_path / "second"
    _dist(
        first,
        "Alpha_Pkg-2.0.dist-info",
        "# a comment\n[actorswarm.plugins]\nalpha.one = alpha.mod:One\n"
        "alpha.two=alpha.mod:Two.Inner [extra]\n\n[console_scripts]\nalpha = alpha:main\n",
    )
    _dist(first, "beta.egg-info", "[actorswarm.plugins]\nbeta.x = beta:X\n")
    # The same distribution again, later on the path: shadowed, as importlib.metadata does.
    _dist(second, "alpha.pkg-1.0.dist-info", "[actorswarm.plugins]\nalpha.old = alpha:Old\n")
    _dist(second, "gamma-3.dist-info", "[other]\ng = gamma:G\n")
    monkeypatch.syspath_prepend(str(second))
    monkeypatch.syspath_prepend(str(first))
    importlib.invalidate_caches()
    ours, theirs = listing("actorswarm.plugins")
    assert ours == theirs
    names = {name for name, _, _ in ours}
    assert {"alpha.one", "alpha.two", "beta.x"} <= names and "alpha.old" not in names
    found = {ep.name: ep for ep in entry_points(group="actorswarm.plugins")}
    assert found["alpha.two"].value == "alpha.mod:Two.Inner [extra]"
    alpha = found["alpha.one"].dist
    assert alpha is not None and alpha.version == "2.0" and alpha.display() == "Alpha-Pkg 2.0"
    beta = found["beta.x"].dist
    assert beta is not None and beta.version == "" and beta.display() == "beta 2.0"


def test_an_archive_on_the_path_hands_the_listing_to_importlib_metadata(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    archive = tmp_path / "zipped.zip"
    with zipfile.ZipFile(archive, "w") as z:
        z.writestr("zipped-1.0.dist-info/METADATA", "Metadata-Version: 2.1\nName: zipped\n")
        z.writestr("zipped-1.0.dist-info/entry_points.txt", "[actorswarm.plugins]\nz.p = z:P\n")
    monkeypatch.syspath_prepend(str(archive))
    importlib.invalidate_caches()
    ours, theirs = listing("actorswarm.plugins")
    assert ours == theirs and ("z.p", "z:P", "zipped") in ours


def test_load_imports_what_the_value_names() -> None:
    assert EntryPoint("j", "json", "g", None).load() is json
    assert EntryPoint("d", "json:dumps", "g", None).load() is json.dumps
    assert EntryPoint("e", "json.decoder:JSONDecoder.decode [x]", "g", None).load() is (
        json.decoder.JSONDecoder.decode
    )
    with pytest.raises(ValueError, match="is not module:attr"):
        EntryPoint("bad", "not a value!", "g", None).load()
    with pytest.raises(AttributeError):
        EntryPoint("missing", "json:nothing_here", "g", None).load()


def test_checking_a_script_in_a_daemon_does_not_import_importlib_metadata() -> None:
    """What a platform's checker does when a script is deployed (in the child process a
    daemon checks it in, ``actorswarm.dsl.isolated``): check it (the checker lists the
    installed plugins and loads their classes)."""
    script = Path(__file__).resolve().parents[2] / "examples" / "branch_merge.xml"
    code = (
        "import json, sys\n"
        "import actorswarm.daemon.run\n"
        "from actorswarm.dsl.isolated import check_in_process\n"
        f"model = check_in_process(open({str(script)!r}).read(), 'branch_merge.xml')\n"
        "print(json.dumps([bool(model.actors), [m for m in ('importlib.metadata', 'email',\n"
        "                  'zipfile', 'csv') if m in sys.modules]]))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True
    )
    assert json.loads(out.stdout.strip().splitlines()[-1]) == [True, []]
