"""The emulated ONVIF PTZ camera on loopback: `OnvifDevice` behind an aiohttp server on the rig's
`onvif://127.0.0.1:PORT`, so a sim rig with `protocol = "onvif"` runs the whole loop over
HTTP/SOAP and WS-Security (DESIGN §9, STYLE 3: the fake speaks the real protocol).

It stands where `HeadEmulator` stands for a serial head, with the calls the `sim` process makes
(`open`, `start`, `close`, `pose_at`, `link_path`): the server runs in a thread of its own with
its own event loop, answers each request `[sim] head_reply_delay_ms` after it came, and moves
the axes of a `HeadMechanics` (the rig's rate and acceleration limits, `head_latency_ms`). The
password is the rig's (its `password_file` or `password_env`), as the camera's would be.
"""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import Callable

from aiohttp import web

from gazed.config import Rig
from gazed.config.servo import OnvifServo
from gazed.messages import HeadPose
from gazed.servo.onvif_head import SCHEME, read_password
from gazed.sim.head_emulator import HeadEmulator, joint_pose
from gazed.sim.head_mechanics import AxisSample, HeadMechanics
from gazed.sim.onvif_device import OnvifDevice

START_TIMEOUT_S = 5.0


class OnvifEmulatorError(RuntimeError):
    """The emulator cannot serve the rig's port (not loopback, taken, no password)."""


def loopback_address(port: str) -> tuple[str, int]:
    host, _, number = port.removeprefix(f"{SCHEME}://").rpartition(":")
    if host not in ("127.0.0.1", "localhost"):
        raise OnvifEmulatorError(f"[servo] port {port!r}: the emulator serves loopback only")
    return "127.0.0.1", int(number)


class OnvifEmulator:
    """The rig's ONVIF camera on loopback; `clock` is the monotonic clock of its mechanism."""

    def __init__(
        self, rig: Rig, *, password: str | None = None, clock: Callable[[], float] = time.monotonic
    ) -> None:
        servo = rig.servo
        if not isinstance(servo, OnvifServo):
            raise OnvifEmulatorError(f"[servo] protocol {servo.protocol} is not onvif")
        self.rig = rig
        self.address = loopback_address(servo.port)
        self.link_path = servo.port
        self._clock = clock
        self._lock = threading.Lock()
        self.mechanics = HeadMechanics(rig.head, rig.sim, clock())
        folder = rig.source_path.parent if rig.source_path is not None else None
        try:
            secret = password if password is not None else read_password(servo, folder)
        except RuntimeError as exc:
            raise OnvifEmulatorError(str(exc)) from exc
        host = f"http://{self.address[0]}:{self.address[1]}"
        self.device = OnvifDevice(servo, self.mechanics, secret, host)
        self.reply_delay_s = rig.sim.head_reply_delay_ms / 1000.0
        self._loop: asyncio.AbstractEventLoop | None = None
        self._runner: web.AppRunner | None = None
        self._thread: threading.Thread | None = None
        self._ready = threading.Event()
        self._failure: BaseException | None = None

    def __enter__(self) -> OnvifEmulator:
        self.open()
        self.start()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def open(self) -> None:
        """Nothing to open before the server starts (it binds in `start`)."""

    def start(self) -> None:
        """Serve from a thread of its own; returns once the port is bound (raises
        `OnvifEmulatorError` if it cannot be)."""
        if self._thread is not None:
            return
        self._ready.clear()
        self._thread = threading.Thread(target=self._run, name="onvif-emulator", daemon=True)
        self._thread.start()
        self._ready.wait(START_TIMEOUT_S)
        if self._failure is not None or not self._ready.is_set():
            self.close()
            raise OnvifEmulatorError(f"cannot serve {self.address}: {self._failure}")

    def close(self) -> None:
        loop, thread = self._loop, self._thread
        if loop is not None and thread is not None and loop.is_running():
            loop.call_soon_threadsafe(loop.stop)
        if thread is not None:
            thread.join(START_TIMEOUT_S)
        self._thread = None

    def _run(self) -> None:
        loop = asyncio.new_event_loop()
        self._loop = loop
        try:
            loop.run_until_complete(self._serve())
        except OSError as exc:
            self._failure = exc
            self._ready.set()
            loop.close()
            return
        self._ready.set()
        try:
            loop.run_forever()
        finally:
            if self._runner is not None:
                loop.run_until_complete(self._runner.cleanup())
            loop.close()

    async def _serve(self) -> None:
        app = web.Application()
        app.router.add_post("/onvif/{service}", self._handle)
        self._runner = web.AppRunner(app, access_log=None)
        await self._runner.setup()
        await web.TCPSite(self._runner, *self.address).start()

    async def _handle(self, request: web.Request) -> web.Response:
        body = await request.read()
        received_s = self._clock()
        with self._lock:
            status, xml = self.device.handle(body, received_s)
        delay_s = received_s + self.reply_delay_s - self._clock()
        if delay_s > 0:
            await asyncio.sleep(delay_s)
        return web.Response(
            status=status, text=xml, content_type="application/soap+xml", charset="utf-8"
        )

    # --- truth -------------------------------------------------------------------------------

    def device_pose_at(self, t_s: float) -> AxisSample:
        with self._lock:
            self.device.advance(min(t_s, self._clock()))
            return self.mechanics.pose_at(t_s)

    def pose_at(self, t_s: float) -> HeadPose:
        """The camera's true joint angles and rates at monotonic `t_s` (for the renderer)."""
        return joint_pose(
            self.rig.head, self.device_pose_at(t_s), zoom_lens=bool(self.rig.camera.zoom_focal_px)
        )

    @property
    def settled(self) -> bool:
        with self._lock:
            return self.mechanics.settled


def head_emulator(rig: Rig) -> HeadEmulator | OnvifEmulator:
    """The emulated head of the rig's `[servo]`: the ONVIF camera for `protocol = "onvif"`,
    otherwise the serial (or VISCA-over-IP) head."""
    if isinstance(rig.servo, OnvifServo):
        return OnvifEmulator(rig)
    return HeadEmulator(rig)
