"""asyncio without :mod:`ssl` until something in the process asks for TLS.

Importing :mod:`asyncio` imports :mod:`ssl` (three of its modules do, to recognise TLS
sockets and to offer TLS connections), and :mod:`ssl` maps OpenSSL's ``libssl`` and
``libcrypto``: with the ``ssl`` module's own objects, about 4.5 MiB resident in a process
that never opens a TLS connection. A daemon does not: Zenoh has its own TLS, operator
packets are checked with libsodium (:mod:`actorswarm.security.ed25519`) and HMAC-SHA256 is
CPython's (:mod:`actorswarm.core.digest`).

:func:`import_asyncio_without_ssl` imports :mod:`asyncio` while ``import ssl`` fails, as
on an interpreter built without OpenSSL, which asyncio supports. From then on, the first
``import ssl`` anywhere in the process (a plugin that opens a TLS connection, a library
such as an HTTP client) loads :mod:`ssl` as usual and hands it to those asyncio modules,
so asyncio's TLS works exactly as if :mod:`ssl` had been there from the start. Until then
no socket can be a TLS one, which is all asyncio's checks ask.

:mod:`actorswarm.daemon` calls it before anything imports :mod:`asyncio`; in a process that
had already imported :mod:`asyncio` (or :mod:`ssl`) it does nothing.
"""

from __future__ import annotations

import sys
from importlib.machinery import ModuleSpec, PathFinder
from types import ModuleType
from typing import Final, Protocol

__all__ = ["ASYNCIO_SSL_USERS", "import_asyncio_without_ssl"]

#: The asyncio modules that keep a module-level ``ssl`` (None when it was not importable).
ASYNCIO_SSL_USERS: Final = ("asyncio.base_events", "asyncio.selector_events", "asyncio.sslproto")


def import_asyncio_without_ssl() -> bool:
    """Import :mod:`asyncio` with :mod:`ssl` deferred (see the module's documentation).
    True when it did so; False when :mod:`asyncio` or :mod:`ssl` was already imported."""
    if "asyncio" in sys.modules or "ssl" in sys.modules:
        return False
    # A None in sys.modules makes `import ssl` raise ImportError, which asyncio handles.
    sys.modules["ssl"] = None  # type: ignore[assignment]
    try:
        import asyncio  # noqa: F401
    finally:
        del sys.modules["ssl"]
    sys.meta_path.insert(0, _SslWatcher())
    return True


class _Loader(Protocol):
    def create_module(self, spec: ModuleSpec) -> ModuleType | None: ...

    def exec_module(self, module: ModuleType) -> None: ...


class _SslWatcher:
    """A finder that finds nothing but :mod:`ssl`, found where the standard path finder
    finds it, with a loader that gives it to asyncio once it is executed. It leaves the
    import system after that first import."""

    def find_spec(
        self, fullname: str, path: object = None, target: ModuleType | None = None
    ) -> ModuleSpec | None:
        if fullname != "ssl":
            return None
        spec = PathFinder.find_spec(fullname)
        if spec is None or spec.loader is None:
            return None
        spec.loader = _HandToAsyncio(spec.loader, self)  # type: ignore[assignment]
        return spec


class _HandToAsyncio:
    """The standard loader of :mod:`ssl`, then :func:`_relink`."""

    def __init__(self, loader: _Loader, watcher: _SslWatcher) -> None:
        self._loader = loader
        self._watcher = watcher

    def create_module(self, spec: ModuleSpec) -> ModuleType | None:
        return self._loader.create_module(spec)

    def exec_module(self, module: ModuleType) -> None:
        self._loader.exec_module(module)
        _relink(module)
        if self._watcher in sys.meta_path:
            sys.meta_path.remove(self._watcher)


def _relink(ssl: ModuleType) -> None:
    """What asyncio's modules would hold had ``ssl`` imported when they did."""
    for name in ASYNCIO_SSL_USERS:
        module = sys.modules.get(name)
        if module is not None and getattr(module, "ssl", None) is None:
            module.ssl = ssl  # type: ignore[attr-defined]
    sslproto = sys.modules.get("asyncio.sslproto")
    # Defined at import only when ssl was there: the errors that mean "call again".
    if sslproto is not None and not hasattr(sslproto, "SSLAgainErrors"):
        sslproto.SSLAgainErrors = (ssl.SSLWantReadError, ssl.SSLSyscallError)  # type: ignore[attr-defined]
