"""Finding plugins by name: entry points, ``module:Class`` paths, and clear refusals.

Third-party packages are installed the way pip leaves them — the package's module next to a
``<name>-<version>.dist-info`` folder holding ``METADATA`` and ``entry_points.txt`` — in a
temporary folder put on ``sys.path``, so discovery goes through the real
:mod:`importlib.metadata` scan without touching the project's environment (which other
test runs share). A real ``pip install`` of a package built from a ``pyproject.toml`` is
tested too where the environment can build one without the network: building needs
``setuptools`` ≥ 70.1 or the ``wheel`` package, and build isolation would fetch them from
the package index.
"""

from __future__ import annotations

import importlib.metadata
import importlib.util
import subprocess
import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path

import pytest

from actorswarm.dsl.plugins import BUILTIN_PLUGINS, ENTRY_POINT_GROUP, installed_plugins
from actorswarm.runtime import registry
from actorswarm.runtime.builtin import EmitAfter, Idle
from actorswarm.runtime.registry import NotAPlugin, PluginNotFound, RegistryError

PLUGIN_MODULE = """
from actorswarm.runtime.plugin import Plugin


class Wave(Plugin):
    bus = "act_bus"

    def step(self, ctx):
        pass


class NotOne:
    pass
"""


@pytest.fixture(autouse=True)
def fresh_registry() -> Iterator[None]:
    registry.refresh()
    yield
    registry.refresh()


@pytest.fixture
def site(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A folder on ``sys.path`` to install packages into; what they import is forgotten
    afterwards."""
    folder = tmp_path / "site"
    folder.mkdir()
    monkeypatch.syspath_prepend(str(folder))
    before = set(sys.modules)
    yield folder
    for name in set(sys.modules) - before:
        del sys.modules[name]


def install(site: Path, dist: str, entry_points: dict[str, str], **modules: str) -> None:
    """Lay out ``dist`` as pip installs it: its modules, and a dist-info with entry points."""
    for module, source in modules.items():
        (site / f"{module}.py").write_text(textwrap.dedent(source))
    info = site / f"{dist.replace('-', '_')}-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: 0.1\n")
    lines = "".join(f"{name} = {value}\n" for name, value in entry_points.items())
    (info / "entry_points.txt").write_text(f"[{ENTRY_POINT_GROUP}]\n{lines}")
    importlib.invalidate_caches()


# --- the built-ins -----------------------------------------------------------------------------


def test_builtins_are_found_through_their_entry_points() -> None:
    found = registry.installed()
    assert found["core.idle"] is Idle
    assert found["core.emit_after"] is EmitAfter
    assert registry.resolve("core.emit_after") is EmitAfter
    eps = {ep.name: ep for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP)}
    assert eps["core.idle"].value == "actorswarm.runtime.builtin:Idle"
    dist = eps["core.idle"].dist
    assert dist is not None and dist.name == "actorswarm"
    assert registry.load_errors() == {}


def test_param_schema_comes_from_the_class() -> None:
    schema = registry.param_schema("core.emit_after")
    assert schema is EmitAfter.params
    assert list(schema) == ["event", "after", "spread_per_platform", "scope"]
    assert registry.param_schema("core.idle") == {}


def test_the_checker_and_the_plugins_agree() -> None:
    """The script checker's built-in table and the plugin classes read params alike, so the
    checker can take its table from the classes."""
    assert set(registry.installed()) <= installed_plugins()
    samples = {
        "event": ["go", "AtoB_event", "two words", ""],
        "after": ["0", "2.5", "1e1", "-1", "soon"],
        "spread_per_platform": ["0", "0.25", "-1", "x"],
        "scope": ["local", "swarm", "global"],
    }
    for plugin, rules in BUILTIN_PLUGINS.items():
        schema = registry.param_schema(plugin)
        assert set(schema) == set(rules), plugin
        for key, rule in rules.items():
            for text in samples[key]:
                verdicts = []
                for parse in (rule.parse, schema[key].parse):
                    try:
                        parse(text)
                        verdicts.append(True)
                    except ValueError:
                        verdicts.append(False)
                assert verdicts[0] == verdicts[1], f"{plugin} {key}={text!r}: {verdicts}"


# --- module:Class paths ------------------------------------------------------------------------


def test_a_module_class_path_resolves(site: Path) -> None:
    assert registry.resolve("actorswarm.runtime.builtin:Idle") is Idle
    (site / "devplugins.py").write_text(PLUGIN_MODULE)
    cls = registry.resolve("devplugins:Wave")
    assert cls.__name__ == "Wave" and cls.bus == "act_bus"
    assert registry.resolve("devplugins:Wave") is cls  # cached


NOT_IN_PLUGIN = "which does not derive from actorswarm.runtime.plugin.Plugin"


@pytest.mark.parametrize(
    ("name", "error", "message"),
    [
        ("", PluginNotFound, "the plugin name '' is empty"),
        ("core.idel", PluginNotFound, "'core.idel' is not installed (did you mean \"core.idle\"?)"),
        ("core.idel", PluginNotFound, "no entry point of that name in group actorswarm.plugins"),
        ("core.idel", PluginNotFound, "installed: core.emit_after, core.idle"),
        ("nobody.ships.this", PluginNotFound, "write it as module:Class (e.g. nobody.ships:this)"),
        ("mod:", PluginNotFound, "is not a valid path: write it as package.module:ClassName"),
        ("a b:C", PluginNotFound, "is not a valid path"),
        ("no_such_pkg.mod:Thing", PluginNotFound, "there is no module named 'no_such_pkg'"),
        ("actorswarm.runtime.builtin:Idel", PluginNotFound, '(did you mean "Idle"?)'),
        ("actorswarm.runtime.builtin:Idel", PluginNotFound, "classes there: EmitAfter, Idle"),
        ("os:sep", NotAPlugin, "names str '/', not a class"),
        ("collections:OrderedDict", NotAPlugin, f"class collections.OrderedDict, {NOT_IN_PLUGIN}"),
        ("actorswarm.runtime.plugin:Plugin", NotAPlugin, "is abstract: it does not implement step"),
    ],
)
def test_junk_names_are_refused_clearly(
    name: str, error: type[RegistryError], message: str
) -> None:
    with pytest.raises(error) as info:
        registry.resolve(name)
    assert message in str(info.value)
    assert isinstance(info.value, LookupError)


def test_modules_that_fail_to_import_are_reported(site: Path) -> None:
    (site / "needs_dep.py").write_text("import not_installed_dependency_xyz\n")
    (site / "crashes.py").write_text("raise RuntimeError('calibration table missing')\n")
    with pytest.raises(PluginNotFound) as info:
        registry.resolve("needs_dep:Thing")
    assert "importing module 'needs_dep' failed: it needs module" in str(info.value)
    assert "'not_installed_dependency_xyz', which is not installed" in str(info.value)
    with pytest.raises(PluginNotFound) as info:
        registry.resolve("crashes:Thing")
    assert "RuntimeError: calibration table missing" in str(info.value)
    assert isinstance(info.value.__cause__, RuntimeError)


def test_a_class_broken_after_definition_is_refused(site: Path) -> None:
    (site / "mutated.py").write_text(PLUGIN_MODULE + "\nWave.bus = 'radio_bus'\n")
    with pytest.raises(NotAPlugin, match="whose declarations are wrong: bus 'radio_bus'"):
        registry.resolve("mutated:Wave")


# --- third-party packages ----------------------------------------------------------------------


def test_an_installed_third_party_plugin_is_found(site: Path) -> None:
    install(site, "acme-waves", {"acme.wave": "acme_waves:Wave"}, acme_waves=PLUGIN_MODULE)
    found = registry.installed()
    assert found["acme.wave"].__module__ == "acme_waves"
    assert {"core.idle", "core.emit_after"} <= set(found)
    assert registry.resolve("acme.wave") is found["acme.wave"]
    assert "acme.wave" in installed_plugins()  # the checker sees it too


def test_installing_while_running_is_picked_up(site: Path) -> None:
    assert "late.wave" not in registry.installed()
    install(site, "late-waves", {"late.wave": "late_waves:Wave"}, late_waves=PLUGIN_MODULE)
    assert "late.wave" not in registry.installed()  # answered from the cache
    assert registry.resolve("late.wave").__name__ == "Wave"  # resolve looks again once
    assert "late.wave" in registry.installed()
    registry.refresh()
    assert "late.wave" in registry.installed(refresh=True)


def test_broken_entry_points_do_not_spoil_the_listing(site: Path) -> None:
    install(
        site,
        "half-broken",
        {
            "good.wave": "hb_plugins:Wave",
            "bad.missing": "hb_nowhere:Wave",
            "bad.notone": "hb_plugins:NotOne",
        },
        hb_plugins=PLUGIN_MODULE,
    )
    found = registry.installed()
    assert "good.wave" in found
    assert "bad.missing" not in found and "bad.notone" not in found
    errors = registry.load_errors()
    assert set(errors) == {"bad.missing", "bad.notone"}
    assert "entry point 'hb_nowhere:Wave' from half-broken 0.1" in errors["bad.missing"]
    assert "could not be loaded: ModuleNotFoundError" in errors["bad.missing"]
    assert "names the class hb_plugins.NotOne, which does not derive" in errors["bad.notone"]
    with pytest.raises(NotAPlugin):
        registry.resolve("bad.notone")


def test_a_name_two_distributions_claim_is_ambiguous(site: Path) -> None:
    install(site, "waves-one", {"dup.wave": "w_one:Wave"}, w_one=PLUGIN_MODULE)
    install(site, "waves-two", {"dup.wave": "w_two:Wave"}, w_two=PLUGIN_MODULE)
    with pytest.raises(PluginNotFound) as info:
        registry.resolve("dup.wave")
    message = str(info.value)
    assert "plugin 'dup.wave' is ambiguous" in message
    assert "w_one:Wave (from waves-one 0.1)" in message
    assert "w_two:Wave (from waves-two 0.1)" in message
    assert "uninstall all but one" in message


def _can_build_offline() -> bool:
    version = importlib.metadata.version("setuptools")
    major, minor = (int(part) for part in version.split(".")[:2])
    return (major, minor) >= (70, 1) or importlib.util.find_spec("wheel") is not None


@pytest.mark.skipif(
    not _can_build_offline(),
    reason="building a package without the network needs setuptools >= 70.1 or wheel",
)
def test_a_pip_installed_package_is_found(tmp_path: Path, site: Path) -> None:
    project = tmp_path / "pipwave"
    (project / "src" / "pipwave").mkdir(parents=True)
    (project / "src" / "pipwave" / "__init__.py").write_text(PLUGIN_MODULE)
    (project / "pyproject.toml").write_text(
        textwrap.dedent(
            """
            [build-system]
            requires = ["setuptools>=61"]
            build-backend = "setuptools.build_meta"

            [project]
            name = "pipwave"
            version = "0.1"

            [project.entry-points."actorswarm.plugins"]
            "pip.wave" = "pipwave:Wave"
            """
        )
    )
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "--no-build-isolation", "-q",
         "--target", str(site), str(project)],
        check=True,
        timeout=120,
    )  # fmt: skip
    importlib.invalidate_caches()
    assert registry.installed(refresh=True)["pip.wave"].__name__ == "Wave"
