"""The page and its WebSocket (aiohttp): frames out at the browser's pace, clicks back in.

- `GET /` is the page, `GET /static/…` its script and style (plain files, no build step).
- `GET /ws` is one WebSocket per page. The server sends:
  - binary messages, one per frame: a 4-byte big-endian length, that many bytes of JSON
    (`seq`, `t_capture_ns`, `width`, `height`, `head`, `overlay`) and the frame's JPEG. The
    next frame goes out only after the page acknowledges this one (`{"type": "ack"}`), so at
    most one frame is in flight per page and a slow browser is sent fewer frames;
  - text messages: `LiveState.snapshot()` about `state_rate_hz` times a second, and the answer
    to a click (`{"type": "selected", ...}`).
  The page sends `{"type": "select", "seq": N, "u": U, "v": V}` (a click on frame N) or
  `{"type": "select"}` (back to the rig's own rule); the server answers with what it published
  on `gaze/select`. The page's buttons send `{"type": "command", "command": C}` for C one of
  park, search, hold and resume; the server publishes it on `gaze/command` and answers
  `{"type": "commanded", ...}`; the gaze's new state comes with the next state message.
- With a password, every request needs HTTP basic auth with it (any user name).
"""

from __future__ import annotations

import asyncio
import base64
import hmac
import json
import struct
import time
from collections import OrderedDict
from collections.abc import Awaitable, Callable
from importlib import resources
from typing import Any

from aiohttp import WSMsgType, web

from gazed.bus import BusError
from gazed.gaze.operator import OPERATOR_COMMANDS
from gazed.messages import GazeCommand, GazeSelect, HeadPose
from gazed.view.frame_feed import FrameFeed
from gazed.view.live_state import LiveState

SENT_POSES_KEPT = 64  # frames a click can still refer to
REALM = 'Basic realm="gazed view"'

Handler = Callable[[web.Request], Awaitable[web.StreamResponse]]


class ViewServer:
    """The page's web application over a `LiveState`, a `FrameFeed` and a way to publish."""

    def __init__(
        self,
        state: LiveState,
        feed: FrameFeed,
        publish_select: Callable[[GazeSelect], None],
        publish_command: Callable[[GazeCommand], None],
        *,
        password: str | None = None,
        state_period_s: float = 0.1,
        on_clients: Callable[[int], None] = lambda n: None,
    ) -> None:
        self.state = state
        self.feed = feed
        self.publish_select = publish_select
        self.publish_command = publish_command
        self.password = password
        self.state_period_s = state_period_s
        self.on_clients = on_clients  # told the number of open pages when it changes
        self.clients = 0
        self.frames_sent = 0
        self.selects = 0
        self.commands = 0

    def app(self) -> web.Application:
        middlewares = [self._auth] if self.password is not None else []
        app = web.Application(middlewares=middlewares)
        static = resources.files("gazed.view") / "static"
        app.router.add_get("/", self._page)
        app.router.add_get("/ws", self._socket)
        app.router.add_static("/static", str(static))
        return app

    @web.middleware
    async def _auth(self, request: web.Request, handler: Handler) -> web.StreamResponse:
        assert self.password is not None
        scheme, _, encoded = request.headers.get("Authorization", "").partition(" ")
        given = ""
        if scheme.lower() == "basic":
            try:
                given = base64.b64decode(encoded).decode("utf-8").partition(":")[2]
            except (ValueError, UnicodeDecodeError):
                given = ""
        if not hmac.compare_digest(given.encode(), self.password.encode()):
            raise web.HTTPUnauthorized(headers={"WWW-Authenticate": REALM})
        return await handler(request)

    async def _page(self, _request: web.Request) -> web.FileResponse:
        return web.FileResponse(str(resources.files("gazed.view") / "static" / "index.html"))

    async def _socket(self, request: web.Request) -> web.WebSocketResponse:
        ws = web.WebSocketResponse(heartbeat=10.0)
        await ws.prepare(request)
        self.clients += 1
        self.on_clients(self.clients)
        acked = asyncio.Event()
        acked.set()
        poses: OrderedDict[int, HeadPose | None] = OrderedDict()
        senders = [
            asyncio.create_task(self._send_frames(ws, acked, poses)),
            asyncio.create_task(self._send_state(ws)),
        ]
        try:
            async for message in ws:
                if message.type != WSMsgType.TEXT:
                    continue
                try:
                    request_body = json.loads(message.data)
                except ValueError:
                    continue
                if not isinstance(request_body, dict):
                    continue
                if request_body.get("type") == "ack":
                    acked.set()
                elif request_body.get("type") == "select":
                    await ws.send_json(self._select(request_body, poses))
                elif request_body.get("type") == "command":
                    await ws.send_json(self._command(request_body.get("command")))
        finally:
            self.clients -= 1
            self.on_clients(self.clients)
            for task in senders:
                task.cancel()
            await asyncio.gather(*senders, return_exceptions=True)
        return ws

    async def _send_frames(
        self,
        ws: web.WebSocketResponse,
        acked: asyncio.Event,
        poses: OrderedDict[int, HeadPose | None],
    ) -> None:
        number = 0
        while not ws.closed:
            await acked.wait()
            item = await self.feed.newer_than(number)
            number = item.number
            jpeg = await self.feed.jpeg(item)
            header = item.frame.header
            head = self.state.pose_at(header.t_capture_ns)
            poses[header.seq] = head
            while len(poses) > SENT_POSES_KEPT:
                poses.popitem(last=False)
            meta = {
                "seq": header.seq,
                "t_capture_ns": header.t_capture_ns,
                "width": header.width,
                "height": header.height,
                "head": head.model_dump() if head is not None else None,
                "overlay": self.state.overlay(head),
            }
            text = json.dumps(meta).encode()
            acked.clear()
            await ws.send_bytes(struct.pack(">I", len(text)) + text + jpeg)
            self.frames_sent += 1

    async def _send_state(self, ws: web.WebSocketResponse) -> None:
        while not ws.closed:
            await ws.send_json(self.state.snapshot())
            await asyncio.sleep(self.state_period_s)

    def _select(
        self, body: dict[str, Any], poses: OrderedDict[int, HeadPose | None]
    ) -> dict[str, Any]:
        """A click on a sent frame (or a return to the rule) as a `GazeSelect`, published."""
        now_ns = time.time_ns()
        if "u" not in body:
            selection = GazeSelect(t_capture_ns=now_ns)
        else:
            seq = body.get("seq")
            head = poses.get(seq) if isinstance(seq, int) else None
            if head is None:
                return {"type": "selected", "ok": False, "message": f"no head pose for frame {seq}"}
            try:
                pixel = (float(body["u"]), float(body["v"]))
                selection = GazeSelect(t_capture_ns=now_ns, pixel_px=pixel, head=head)
            except (KeyError, TypeError, ValueError) as exc:
                return {"type": "selected", "ok": False, "message": f"bad click: {exc}"}
        try:
            self.publish_select(selection)
        except BusError as exc:
            return {"type": "selected", "ok": False, "message": str(exc)}
        self.selects += 1
        return {
            "type": "selected",
            "ok": True,
            "pixel_px": selection.pixel_px,
            "message": "selected" if selection.pixel_px else "back to the rig's rule",
        }

    def _command(self, name: object) -> dict[str, Any]:
        """An operator's button (park, search, hold, resume) as a `GazeCommand`, published."""
        if name not in OPERATOR_COMMANDS:
            allowed = ", ".join(OPERATOR_COMMANDS)
            return {"type": "commanded", "ok": False, "message": f"{name!r}: not one of {allowed}"}
        command = GazeCommand(
            t_capture_ns=time.time_ns(), command=name, request_id=f"view-{self.commands + 1}"
        )
        try:
            self.publish_command(command)
        except BusError as exc:
            return {"type": "commanded", "ok": False, "command": name, "message": str(exc)}
        self.commands += 1
        return {"type": "commanded", "ok": True, "command": name, "message": f"{name} sent"}
