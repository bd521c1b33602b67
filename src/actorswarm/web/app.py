"""The ASGI app of the web ground station: the page's files and one WebSocket.

``GET /`` is the page; ``/static/…`` its scripts and style (shipped in the package: no
build step, no network); ``GET /api/state`` the current ``hello``, ``frame`` and ``swarm``
messages as one JSON object, for scripts and for a look with ``curl``.

``/ws`` streams the source's messages (:mod:`actorswarm.web.source`) and takes the page's
requests (:mod:`actorswarm.web.protocol`). On connecting, a page gets ``hello``, ``swarm``
and ``frame`` at once; then frames at ``frame_hz`` (only when something moved: an ended
simulation sends none), ``swarm`` at ``swarm_hz``, and every ``steps``, ``outcome`` and
``hello`` as it happens. Only the connection's own sender writes to its socket; what the
receiving side has to say (an ``acb``, a refused request) goes through the same queue.
A command runs as a task of its own, so a page can send another (or inspect a platform)
while one is waiting for the swarm's answers.

Every request passes :mod:`actorswarm.web.access` first.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import msgspec
from fastapi import FastAPI, Request, Response, WebSocket, WebSocketDisconnect
from fastapi.responses import FileResponse, JSONResponse, PlainTextResponse
from fastapi.staticfiles import StaticFiles

from actorswarm.web import protocol
from actorswarm.web.access import COOKIE, Access
from actorswarm.web.source import SwarmSource

__all__ = ["STATIC", "create_app"]

#: The page's files, shipped in the package.
STATIC = Path(__file__).with_name("static")

_ENCODE = msgspec.json.Encoder()
_NEEDS_TOKEN = (
    "This ground station asks for its access token. Open the address it printed when it "
    "started (it ends in ?token=...), or send 'Authorization: Bearer TOKEN'.\n"
)
_WRONG_HOST = (
    "This ground station only answers to localhost / 127.0.0.1. Open it by that name, or "
    "start it with --host and a --token to serve other machines.\n"
)
#: WebSocket close codes (the 4000s are the application's own).
CLOSE_REFUSED, CLOSE_DROPPED = 4403, 4409


class _Every:
    """``fn()``, computed at most once per ``period`` wall seconds, however many pages
    ask (the swarm view of 200 platforms reads 200 sets of control blocks)."""

    def __init__(self, fn: Callable[[], dict[str, Any]], period: float) -> None:
        self.fn, self.period = fn, period
        self._at = -1e18
        self._value: dict[str, Any] = {}

    def __call__(self) -> dict[str, Any]:
        now = time.monotonic()
        if now - self._at >= self.period:
            self._value, self._at = self.fn(), now
        return self._value


def _text(message: dict[str, Any]) -> str:
    return _ENCODE.encode(message).decode()


def _refusal(text: str, error: str) -> dict[str, Any]:
    """The outcome of a request that could not even be read."""
    request_id = ""
    with contextlib.suppress(ValueError, TypeError, AttributeError):
        request_id = str(json.loads(text).get("id", ""))[:64]
    return {
        "type": "outcome",
        "id": request_id,
        "op": "?",
        "asked": "",
        "t": None,
        "state": "done",
        "ok": False,
        "message": error,
        "targets": [],
        "answers": {},
        "diagnostics": [],
    }


def create_app(
    source: SwarmSource,
    *,
    access: Access | None = None,
    frame_hz: float = 10.0,
    swarm_hz: float = 1.0,
) -> FastAPI:
    """The app serving ``source``: started and stopped with the app (its lifespan)."""
    guard = access or Access()
    frame_period, swarm_period = 1.0 / frame_hz, 1.0 / swarm_hz
    swarm_view = _Every(source.swarm_view, swarm_period / 2)
    commands: set[asyncio.Task[Any]] = set()

    @asynccontextmanager
    async def lifespan(_: FastAPI) -> AsyncIterator[None]:
        await source.start()
        try:
            yield
        finally:
            for task in list(commands):
                task.cancel()
            await source.stop()

    app = FastAPI(
        title="actorswarm ground station",
        lifespan=lifespan,
        docs_url=None,
        redoc_url=None,
        openapi_url=None,
    )

    @app.middleware("http")
    async def checked(
        request: Request, call_next: Callable[[Request], Awaitable[Response]]
    ) -> Response:
        if not guard.host_ok(request.headers.get("host")):
            return PlainTextResponse(_WRONG_HOST, status_code=421)
        given = request.query_params.get("token")
        if not guard.token_ok(
            query=given,
            cookie=request.cookies.get(COOKIE),
            authorization=request.headers.get("authorization"),
        ):
            return PlainTextResponse(_NEEDS_TOKEN, status_code=401)
        response = await call_next(request)
        if guard.token is not None and given is not None:
            # The page's own files and socket then carry it without the URL.
            response.set_cookie(COOKIE, given, httponly=True, samesite="strict")
        return response

    @app.get("/", include_in_schema=False)
    async def index() -> FileResponse:
        return FileResponse(STATIC / "index.html", headers={"Cache-Control": "no-cache"})

    app.mount("/static", StaticFiles(directory=STATIC), name="static")

    @app.get("/api/state")
    async def state() -> JSONResponse:
        return JSONResponse(
            {"hello": source.hello(), "frame": source.frame(), "swarm": swarm_view()}
        )

    async def receive(websocket: WebSocket, queue: asyncio.Queue[dict[str, Any] | None]) -> None:
        def reply(message: dict[str, Any]) -> None:
            with contextlib.suppress(asyncio.QueueFull):
                queue.put_nowait(message)

        try:
            while True:
                text = await websocket.receive_text()
                try:
                    request = protocol.decode(text)
                except protocol.ProtocolError as exc:
                    reply(_refusal(text, str(exc)))
                    continue
                if isinstance(request, protocol.Inspect):
                    reply(source.inspect(request.platform))
                    continue
                task = asyncio.create_task(source.execute(request))
                commands.add(task)
                task.add_done_callback(commands.discard)
        except (WebSocketDisconnect, RuntimeError):
            pass
        finally:
            with contextlib.suppress(asyncio.QueueFull):
                queue.put_nowait(None)

    async def stream(websocket: WebSocket, queue: asyncio.Queue[dict[str, Any] | None]) -> None:
        loop = asyncio.get_running_loop()
        await websocket.send_text(_text(source.hello()))
        await websocket.send_text(_text(swarm_view()))
        last = source.frame()
        await websocket.send_text(_text(last))
        next_frame = loop.time() + frame_period
        next_swarm = loop.time() + swarm_period
        while True:
            wait = max(0.0, min(next_frame, next_swarm) - loop.time())
            try:
                message = await asyncio.wait_for(queue.get(), wait)
            except TimeoutError:
                pass
            else:
                if message is None:  # the page left, or fell too far behind
                    return
                await websocket.send_text(_text(message))
            now = loop.time()
            if now >= next_frame:
                frame = source.frame()
                if frame is not last:
                    await websocket.send_text(_text(frame))
                    last = frame
                next_frame = now + frame_period
            if now >= next_swarm:
                await websocket.send_text(_text(swarm_view()))
                next_swarm = now + swarm_period

    @app.websocket("/ws")
    async def socket(websocket: WebSocket) -> None:
        headers = websocket.headers
        host = headers.get("host")
        allowed = (
            guard.host_ok(host)
            and guard.origin_ok(headers.get("origin"), host)
            and guard.token_ok(
                query=websocket.query_params.get("token"),
                cookie=websocket.cookies.get(COOKIE),
                authorization=headers.get("authorization"),
            )
        )
        if not allowed:
            await websocket.close(code=CLOSE_REFUSED)
            return
        await websocket.accept()
        queue = source.hub.subscribe()
        receiving = asyncio.create_task(receive(websocket, queue))
        try:
            await stream(websocket, queue)
        except (WebSocketDisconnect, RuntimeError):
            pass
        finally:
            source.hub.unsubscribe(queue)
            receiving.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await receiving
        with contextlib.suppress(RuntimeError, WebSocketDisconnect):
            await websocket.close(code=CLOSE_DROPPED)

    return app
