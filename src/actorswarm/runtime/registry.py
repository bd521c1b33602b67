"""Finding plugin classes by the names task scripts use.

Theory of operation
-------------------
A script names a plugin in one of two ways (docs/design.md §5):

* an **entry-point name** such as ``core.emit_after`` or ``formation.arrow``: a
  distribution installed in this environment declares it in the group
  :data:`ENTRY_POINT_GROUP` (in its ``pyproject.toml``:
  ``[project.entry-points."actorswarm.plugins"]`` ``"formation.arrow" =
  "mypkg.formations:Arrow"``). This is how plugins are shipped.
* a **path** ``package.module:ClassName``: the module is imported and the class taken from
  it. Handy while developing a plugin, before it is packaged.

Either way the object found must be a concrete subclass of
:class:`~actorswarm.runtime.plugin.Plugin`; anything else is refused with
:class:`NotAPlugin`, and a name that leads nowhere with :class:`PluginNotFound`, whose
message says what was tried and what to do.

The listing of entry points and every class loaded are cached: resolving a plugin happens
on every actor start, which must stay well under a millisecond. :func:`refresh` forgets the
cache (after installing a package while running); :func:`resolve` also refreshes once on
its own before it reports a name as not installed. Two distributions that register one name
for different classes are refused as ambiguous rather than picked from at random.
"""

from __future__ import annotations

import importlib
import inspect
import re
from collections.abc import Mapping
from typing import TYPE_CHECKING, Final

from actorswarm.runtime.plugin import Param, Plugin
from actorswarm.suggest import did_you_mean as _did_you_mean

if TYPE_CHECKING:
    from actorswarm.runtime.entry_points import EntryPoint

__all__ = [
    "ENTRY_POINT_GROUP",
    "NotAPlugin",
    "PluginNotFound",
    "RegistryError",
    "installed",
    "load_errors",
    "param_schema",
    "refresh",
    "resolve",
]

#: The entry-point group plugins register under.
ENTRY_POINT_GROUP: Final = "actorswarm.plugins"

_PATH = re.compile(
    r"(?P<module>[A-Za-z_]\w*(?:\.[A-Za-z_]\w*)*):(?P<attr>[A-Za-z_]\w*(?:\.[A-Za-z_]\w*)*)"
)


class RegistryError(LookupError):
    """A plugin name could not be turned into a plugin class."""


class PluginNotFound(RegistryError):
    """No plugin class under that name: not installed, a module that does not import, or a
    path to nothing. The message says what was tried."""


class NotAPlugin(RegistryError):
    """The name leads to something that is not a concrete :class:`Plugin` subclass."""


class _Cache:
    """What has been looked up: the entry points by name (None: not listed yet), every
    class resolved by the name it was asked for, why entry points failed to load in the
    last full listing, and whether that listing is complete."""

    def __init__(self) -> None:
        self.listing: dict[str, list[EntryPoint]] | None = None
        self.classes: dict[str, type[Plugin]] = {}
        self.errors: dict[str, str] = {}
        self.complete = False

    def clear(self) -> None:
        self.listing = None
        self.classes.clear()
        self.errors.clear()
        self.complete = False

    def entry_points(self) -> dict[str, list[EntryPoint]]:
        if self.listing is None:
            # Imported when a plugin is first looked up, not with the module: a daemon
            # without a script never needs it.
            from actorswarm.runtime.entry_points import entry_points

            listing: dict[str, list[EntryPoint]] = {}
            for ep in entry_points(group=ENTRY_POINT_GROUP):
                same = listing.setdefault(ep.name, [])
                # One distribution seen twice on the path registers the same value twice.
                if all(other.value != ep.value for other in same):
                    same.append(ep)
            self.listing = listing
        return self.listing


_cache = _Cache()


def refresh() -> None:
    """Forget every cached listing and class, so the next call looks at the environment
    again (after a package was installed or removed while running)."""
    _cache.clear()


def installed(*, refresh: bool = False) -> dict[str, type[Plugin]]:
    """Every plugin installed in this environment, by entry-point name (sorted).

    An entry point that cannot be loaded, or does not name a plugin, is left out rather than
    spoiling the list; :func:`load_errors` says why. ``refresh=True`` looks at the
    environment again instead of answering from the cache.
    """
    cache = _cache
    if refresh:
        cache.clear()
    if not cache.complete:
        cache.errors.clear()
        for name in sorted(cache.entry_points()):
            try:
                resolve(name)
            except RegistryError as exc:
                cache.errors[name] = str(exc)
        cache.complete = True
    names = sorted(cache.entry_points())
    return {name: cache.classes[name] for name in names if name in cache.classes}


def load_errors() -> dict[str, str]:
    """Why each entry point left out of :func:`installed` could not be used, by name."""
    installed()
    return dict(_cache.errors)


def resolve(name: str) -> type[Plugin]:
    """The plugin class a script's plugin name stands for: an entry-point name, or a
    ``package.module:ClassName`` path. Raises :class:`PluginNotFound` or
    :class:`NotAPlugin` with what was tried and what to do."""
    found = _cache.classes.get(name)
    if found is not None:
        return found
    if not isinstance(name, str) or not name.strip():
        raise PluginNotFound(f"the plugin name {name!r} is empty; name an installed plugin")
    cls = _from_path(name) if ":" in name else _from_entry_point(name)
    _cache.classes[name] = cls
    return cls


def param_schema(name: str) -> Mapping[str, Param]:
    """The params the plugin ``name`` accepts (its :attr:`Plugin.params`), by key."""
    return resolve(name).params


def _from_entry_point(name: str) -> type[Plugin]:
    candidates = _cache.entry_points().get(name)
    if candidates is None:
        _cache.listing = None  # something may have been installed since it was listed
        _cache.complete = False
        candidates = _cache.entry_points().get(name)
    if candidates is None:
        known = sorted(_cache.entry_points())
        hint = _did_you_mean(name, known)
        listing = ", ".join(known) or "none"
        path_hint = (
            f"; to name a class by its path, write it as module:Class (e.g. "
            f"{name.rpartition('.')[0]}:{name.rpartition('.')[2]})"
            if name.count(".") >= 2
            else ""
        )
        raise PluginNotFound(
            f"plugin {name!r} is not installed{hint}: no entry point of that name in group "
            f"{ENTRY_POINT_GROUP} (installed: {listing}); install the package that provides "
            f"it, or fix the name{path_hint}"
        )
    if len(candidates) > 1:
        sources = "; ".join(f"{ep.value} (from {_dist(ep)})" for ep in candidates)
        raise PluginNotFound(
            f"plugin {name!r} is ambiguous: several installed distributions register it in "
            f"group {ENTRY_POINT_GROUP}: {sources}; uninstall all but one"
        )
    ep = candidates[0]
    origin = f"plugin {name!r} (entry point {ep.value!r} from {_dist(ep)})"
    try:
        obj = ep.load()
    except Exception as exc:
        raise PluginNotFound(
            f"{origin} could not be loaded: {type(exc).__name__}: {exc}; reinstall the "
            "package, or check that it works in this Python environment"
        ) from exc
    return _check_class(obj, origin)


def _dist(ep: EntryPoint) -> str:
    return "an unknown distribution" if ep.dist is None else ep.dist.display()


def _from_path(name: str) -> type[Plugin]:
    match = _PATH.fullmatch(name.strip())
    if match is None:
        raise PluginNotFound(
            f"plugin {name!r} is not a valid path: write it as package.module:ClassName"
        )
    module_name, attr = match["module"], match["attr"]
    origin = f"plugin {name!r}"
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        missing = exc.name or ""
        if missing == module_name or module_name.startswith(missing + "."):
            raise PluginNotFound(
                f"{origin}: tried to import module {module_name!r}, and there is no module "
                f"named {missing!r}; install the package that provides it, or fix the path"
            ) from exc
        raise PluginNotFound(
            f"{origin}: importing module {module_name!r} failed: it needs module "
            f"{missing!r}, which is not installed"
        ) from exc
    except Exception as exc:
        raise PluginNotFound(
            f"{origin}: importing module {module_name!r} failed: {type(exc).__name__}: {exc}"
        ) from exc
    obj: object = module
    for part in attr.split("."):
        try:
            obj = getattr(obj, part)
        except AttributeError:
            plugins = [
                n
                for n, value in vars(module).items()
                if inspect.isclass(value) and issubclass(value, Plugin) and value is not Plugin
            ]
            listing = f" (plugin classes there: {', '.join(sorted(plugins))})" if plugins else ""
            raise PluginNotFound(
                f"{origin}: module {module_name!r} has no {attr!r}"
                f"{_did_you_mean(part, plugins)}{listing}"
            ) from None
    return _check_class(obj, origin)


def _check_class(obj: object, origin: str) -> type[Plugin]:
    base = f"{Plugin.__module__}.{Plugin.__qualname__}"
    if not inspect.isclass(obj):
        raise NotAPlugin(
            f"{origin} names {type(obj).__name__} {obj!r:.60}, not a class; a plugin is a "
            f"class derived from {base}"
        )
    full = f"{obj.__module__}.{obj.__qualname__}"
    if not issubclass(obj, Plugin):
        raise NotAPlugin(
            f"{origin} names the class {full}, which does not derive from {base}; derive it "
            "from Plugin and check it with actorswarm.testing.check_plugin"
        )
    if inspect.isabstract(obj):
        missing = ", ".join(sorted(getattr(obj, "__abstractmethods__", ())))
        raise NotAPlugin(
            f"{origin} names the class {full}, which is abstract: it does not implement {missing}"
        )
    problems = obj.declaration_problems()
    if problems:
        raise NotAPlugin(
            f"{origin} names the class {full}, whose declarations are wrong: " + "; ".join(problems)
        )
    return obj
