"""Where ``task verify``'s runs happen: in this process, in worker processes on this
machine's cores, or on a Ray cluster (the optional extra ``actorswarm[ray]``).

:class:`Pool` runs a list of jobs — each ``fn(*args)`` with a picklable module-level ``fn``
— and hands every result back, in this process, as it arrives (:meth:`Pool.map`). Every
job's result depends on its arguments only, so where it ran changes nothing but the order
of arrival. A ``KeyboardInterrupt`` while waiting cancels what has not started, and
propagates: the caller keeps what arrived before it.

Ray is imported only for ``--ray``; an address that does not answer is refused within a few
seconds with :class:`RayUnavailable`, before anything runs.
"""

from __future__ import annotations

import multiprocessing
import signal
import socket
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from typing import Any

__all__ = ["Pool", "RayUnavailable", "check_ray_address"]

Job = tuple[Any, ...]

#: Seconds to wait for a Ray cluster's address to accept a connection.
RAY_CONNECT_TIMEOUT = 5.0


class RayUnavailable(RuntimeError):
    """``--ray``: Ray is not installed, or its cluster does not answer."""


def _ignore_interrupt() -> None:
    # Ctrl-C reaches the whole process group: the parent alone handles it.
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _call(fn: Callable[..., Any], args: Job) -> Any:
    return fn(*args)


def _call_chunk(fn: Callable[..., Any], jobs: list[Job]) -> list[Any]:
    return [fn(*args) for args in jobs]


class Pool:
    """``workers`` processes on this machine (1: this process, no pool), or the Ray cluster
    at ``ray`` (``local``: one started for this command; ``auto``: the one ``ray start``
    made on this machine; ``HOST:PORT`` or ``ray://HOST:PORT``: a cluster's head)."""

    def __init__(self, *, workers: int = 1, ray: str | None = None) -> None:
        if workers < 1:
            raise ValueError(f"workers must be >= 1, got {workers}")
        self.workers = workers
        self.ray = ray
        self._ray_module: Any = None
        if ray is not None:
            self._ray_module = _connect_ray(ray)

    def describe(self) -> str:
        if self._ray_module is not None:
            cpus = int(self._ray_module.cluster_resources().get("CPU", 0))
            return f"the Ray cluster at {self.ray} ({cpus} CPUs)"
        return f"{self.workers} worker(s) on this machine"

    def close(self) -> None:
        if self._ray_module is not None and self.ray == "local":
            self._ray_module.shutdown()

    def map(
        self, fn: Callable[..., Any], jobs: Sequence[Job], *, chunk: int = 1
    ) -> Iterator[tuple[int, Any]]:
        """``(index of the job, fn(*job))`` for every job, as each finishes. ``chunk``:
        jobs per task in local worker processes (cheap jobs travel in groups)."""
        if self._ray_module is not None:
            yield from self._map_ray(fn, jobs)
        elif self.workers == 1 or len(jobs) <= 1:
            for i, job in enumerate(jobs):
                yield i, fn(*job)
        else:
            yield from self._map_local(fn, jobs, max(1, chunk))

    def _map_local(
        self, fn: Callable[..., Any], jobs: Sequence[Job], chunk: int
    ) -> Iterator[tuple[int, Any]]:
        starts = list(range(0, len(jobs), chunk))
        # "spawn": a fresh interpreter per worker, safe while this process runs a progress
        # display's thread.
        executor = ProcessPoolExecutor(
            max_workers=min(self.workers, len(starts)),
            mp_context=multiprocessing.get_context("spawn"),
            initializer=_ignore_interrupt,
        )
        try:
            pending: dict[Future[list[Any]], int] = {
                executor.submit(_call_chunk, fn, list(jobs[s : s + chunk])): s for s in starts
            }
            while pending:
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                for future in done:
                    start = pending.pop(future)
                    for offset, result in enumerate(future.result()):
                        yield start + offset, result
        finally:
            executor.shutdown(wait=True, cancel_futures=True)

    def _map_ray(self, fn: Callable[..., Any], jobs: Sequence[Job]) -> Iterator[tuple[int, Any]]:
        ray = self._ray_module
        remote = ray.remote(_call)
        refs = {remote.remote(fn, job): i for i, job in enumerate(jobs)}
        try:
            while refs:
                done, _ = ray.wait(list(refs), num_returns=1)
                for ref in done:
                    yield refs.pop(ref), ray.get(ref)
        finally:
            for ref in refs:
                ray.cancel(ref, force=True)


def check_ray_address(address: str) -> tuple[str, int] | None:
    """``(host, port)`` of a ``HOST:PORT`` or ``ray://HOST:PORT`` address (None for
    ``local`` and ``auto``); ValueError for anything else."""
    if address in ("local", "auto"):
        return None
    rest = address.removeprefix("ray://")
    host, sep, port = rest.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ValueError(
            f"--ray: {address!r} is not a Ray address; give HOST:PORT (a cluster's head, as "
            "`ray start --head` prints it), ray://HOST:PORT, auto or local"
        )
    return host, int(port)


def _connect_ray(address: str) -> Any:
    where = check_ray_address(address)
    try:
        import ray
    except ImportError:
        raise RayUnavailable(
            "--ray needs Ray: pip install 'actorswarm[ray]' (or leave out --ray to use this "
            "machine's cores)"
        ) from None
    if where is not None:
        try:
            socket.create_connection(where, timeout=RAY_CONNECT_TIMEOUT).close()
        except OSError as exc:
            raise RayUnavailable(
                f"--ray {address}: no Ray cluster answers there ({exc.strerror or exc}); "
                "start one with `ray start --head` or check the address"
            ) from None
    try:
        ray.init(
            address=None if address == "local" else address,
            include_dashboard=False,
            log_to_driver=False,
            configure_logging=False,
        )
    except Exception as exc:  # Ray raises ConnectionError, RuntimeError, its own types
        raise RayUnavailable(f"--ray {address}: Ray could not connect: {exc}") from None
    return ray
