"""An MJPEG-over-HTTP stream of the newest frame: what a browser, OBS or ffmpeg opens.

    with MjpegServer(port=8081) as server:        # serves http://127.0.0.1:8081/stream.mjpg
        server.publish(frame)                     # from the loop, never blocks

`GET /stream.mjpg` answers `multipart/x-mixed-replace` with one JPEG part per frame;
`GET /snapshot.jpg` answers the newest frame alone. The loop only hands over its newest frame
(`publish`): each client is sent the newest frame whenever it has taken the last one, so a slow
client skips frames and never holds up the loop or the other clients. A frame is encoded once,
when a client first asks for it, and only while someone watches.

The server runs aiohttp in its own thread and event loop. It listens on loopback unless given
another host (the rig says so explicitly).
"""

from __future__ import annotations

import asyncio
import contextlib
import threading

import cv2
import numpy as np
from aiohttp import web

BOUNDARY = "gazedframe"
JPEG_QUALITY = 80
START_TIMEOUT_S = 5.0
IDLE_CHECK_S = 0.5  # while no frame comes, how often a stream checks that its client is there


class MjpegServer:
    """The newest published frame, served as MJPEG on `host:port`."""

    def __init__(self, port: int, host: str = "127.0.0.1", jpeg_quality: int = JPEG_QUALITY):
        self.host = host
        self.port = port
        self.jpeg_quality = jpeg_quality
        self.clients = 0
        self.frames_sent = 0
        self._frame: np.ndarray | None = None
        self._jpeg: bytes | None = None
        self._sequence = 0
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._new_frame: asyncio.Condition | None = None
        self._runner: web.AppRunner | None = None
        self._started = threading.Event()
        self._error: BaseException | None = None
        self._closing = False
        self._wakers: set[asyncio.Future[None]] = set()

    def __enter__(self) -> MjpegServer:
        self.start()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.stop()

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}/stream.mjpg"

    def start(self) -> None:
        """Listen; raises OSError if the port cannot be bound."""
        self._thread = threading.Thread(target=self._serve, name="mjpeg", daemon=True)
        self._thread.start()
        if not self._started.wait(START_TIMEOUT_S):
            raise OSError(f"the MJPEG server on {self.host}:{self.port} did not start")
        if self._error is not None:
            raise OSError(f"cannot serve MJPEG on {self.host}:{self.port}: {self._error}")

    def stop(self) -> None:
        if self._loop is not None and self._thread is not None:
            asyncio.run_coroutine_threadsafe(self._shutdown(), self._loop).result(START_TIMEOUT_S)
            self._thread.join(START_TIMEOUT_S)
        self._thread = None

    def publish(self, frame: np.ndarray) -> None:
        """Hand over the newest frame (grey or BGR); returns at once."""
        with self._lock:
            self._frame = frame
            self._jpeg = None
            self._sequence += 1
        if self._loop is not None and self.clients:
            self._loop.call_soon_threadsafe(self._notify)

    # --- the server thread -------------------------------------------------------------------

    def _serve(self) -> None:
        self._loop = asyncio.new_event_loop()
        asyncio.set_event_loop(self._loop)
        try:
            self._loop.run_until_complete(self._open())
        except OSError as exc:
            self._error = exc
            self._started.set()
            return
        self._started.set()
        self._loop.run_forever()
        self._loop.close()

    async def _open(self) -> None:
        self._new_frame = asyncio.Condition()
        app = web.Application()
        app.router.add_get("/stream.mjpg", self._stream)
        app.router.add_get("/snapshot.jpg", self._snapshot)
        self._runner = web.AppRunner(app, handle_signals=False)
        await self._runner.setup()
        await web.TCPSite(self._runner, self.host, self.port).start()

    async def _shutdown(self) -> None:
        self._closing = True
        if self._new_frame is not None:
            async with self._new_frame:
                self._new_frame.notify_all()
        if self._runner is not None:
            await self._runner.cleanup()
        assert self._loop is not None
        self._loop.call_soon(self._loop.stop)

    def _notify(self) -> None:
        async def wake() -> None:
            assert self._new_frame is not None
            async with self._new_frame:
                self._new_frame.notify_all()

        task = asyncio.ensure_future(wake())
        self._wakers.add(task)  # held until done: the loop keeps only weak references
        task.add_done_callback(self._wakers.discard)

    def _newest(self) -> tuple[int, bytes | None]:
        """The newest frame's sequence number and JPEG, encoding it on first demand."""
        with self._lock:
            if self._jpeg is None and self._frame is not None:
                ok, encoded = cv2.imencode(
                    ".jpg", self._frame, [cv2.IMWRITE_JPEG_QUALITY, self.jpeg_quality]
                )
                self._jpeg = encoded.tobytes() if ok else None
            return self._sequence, self._jpeg

    async def _snapshot(self, request: web.Request) -> web.StreamResponse:
        del request
        _, jpeg = self._newest()
        if jpeg is None:
            raise web.HTTPServiceUnavailable(text="no frame yet")
        return web.Response(body=jpeg, content_type="image/jpeg")

    async def _stream(self, request: web.Request) -> web.StreamResponse:
        response = web.StreamResponse(
            headers={
                "Content-Type": f"multipart/x-mixed-replace; boundary={BOUNDARY}",
                "Cache-Control": "no-cache, no-store",
            }
        )
        await response.prepare(request)
        assert self._new_frame is not None
        self.clients += 1
        sent = -1
        try:
            while not self._closing and _connected(request):
                sequence, jpeg = self._newest()
                if sequence == sent or jpeg is None:
                    async with self._new_frame:
                        # woken by a frame, or after a while to notice a client that left
                        with contextlib.suppress(TimeoutError):
                            await asyncio.wait_for(self._new_frame.wait(), IDLE_CHECK_S)
                    continue
                head = (
                    f"--{BOUNDARY}\r\nContent-Type: image/jpeg\r\n"
                    f"Content-Length: {len(jpeg)}\r\n\r\n"
                ).encode()
                await response.write(head + jpeg + b"\r\n")  # waits while the client is slow
                sent = sequence
                self.frames_sent += 1
        except (ConnectionResetError, asyncio.CancelledError):
            pass
        finally:
            self.clients -= 1
        return response


def _connected(request: web.Request) -> bool:
    transport = request.transport
    return transport is not None and not transport.is_closing()
