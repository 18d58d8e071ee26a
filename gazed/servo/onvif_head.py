"""The ONVIF PTZ head (`[servo] protocol = "onvif"`): an IP camera driven over HTTP/SOAP with
onveef, standing where a serial head has a codec on a transport (`ServoDriver`), with the calls
the head link makes of a driver (`connect`, `set_position`, `query_position`, `stop`).

- connect: the device's services (GetServices, explicitly, so a refused password or a dead
  host is an error and not "no Media service"), GetProfiles (the rig's `profile` or the first
  with a PTZ configuration), GetNodes and GetConfigurationOptions for the spaces and ranges;
- set-points are AbsoluteMove in the absolute generic space, mapped from device angles by the
  rig's `pan_range_deg`/`tilt_range_deg`; `set_speed` is ContinuousMove (speed mode), with the
  camera's own timeout as a second stop; `stop` is Stop; `goto_preset` is GotoPreset (park);
- GetStatus is the odometry, dated halfway through its exchange. Moves are judged by position,
  never by MoveStatus (some cameras never leave MOVING).

Failures map onto the link's: a timeout is `ServoTimeout`, a refused or dropped connection or
refused credentials a `LinkError` (the link reconnects with backoff), a SOAP fault or an
operation the camera does not have a `DeviceError` (the camera did not move, the link stays),
a reply that is not the expected XML a `CodecError` (counted as a bad frame).
"""

from __future__ import annotations

import logging
import math
import os
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
from onveef import OnvifClient, OnvifEndpoint
from onveef.exceptions import (
    OnvifAuthError,
    OnvifError,
    OnvifServiceUnavailableError,
    OnvifTimeoutError,
    OnvifTransportError,
)
from onveef.transport import OnvifCredentials

from gazed.config.servo import OnvifServo
from gazed.servo import onvif_ptz
from gazed.servo.codec import CodecError, HandshakeError
from gazed.servo.digital_head import InstantLine
from gazed.servo.driver import DeviceError, DevicePosition, ServoTimeout
from gazed.servo.onvif_ptz import AxisSpace
from gazed.servo.transport import LinkError, NotConnectedError

SCHEME = "onvif"

# httpx logs every request at INFO: at the odometry and command rates, lines every few ms in
# the servo's log, each written in the loop
logging.getLogger("httpx").setLevel(logging.WARNING)


class PasswordError(RuntimeError):
    """The ONVIF password is neither in the rig's password file nor in its variable."""


def read_password(
    servo: OnvifServo, folder: Path | None = None, environ: dict[str, str] | None = None
) -> str:
    """The password from `password_file` (its first line; a relative path is taken from
    `folder`, the rig file's) or the `password_env` variable."""
    if servo.password_file is not None:
        path = Path(servo.password_file)
        if folder is not None and not path.is_absolute():
            path = folder / path
        try:
            return path.read_text().splitlines()[0]
        except (OSError, IndexError) as exc:
            raise PasswordError(f"password_file {servo.password_file}: {exc}") from exc
    value = (os.environ if environ is None else environ).get(servo.password_env)
    if value is None:
        raise PasswordError(
            f"no ONVIF password: set password_file or the {servo.password_env} variable"
        )
    return value


def device_url(servo: OnvifServo) -> str:
    host_port = servo.port.removeprefix(f"{SCHEME}://")
    return f"http://{host_port}{servo.device_path}"


@dataclass
class OnvifTraits:
    """What the head link asks of a protocol, for the ONVIF head: it reports its position, its
    pan does not wrap, a unit is the camera's smallest step of its generic space."""

    resolution_rad: tuple[float, float] = (0.0, 0.0)
    protocol: str = "onvif"
    can_report_position: bool = True
    pan_wraps: bool = False
    replies_identify_themselves: bool = False
    stop_needs_position: bool = False
    discarded_bytes: int = 0
    bad_frames: int = 0


@dataclass(frozen=True)
class Capabilities:
    """What the camera's PTZ node offers."""

    absolute: bool
    relative: bool
    continuous: bool
    velocity_max: tuple[float, float]  # the ends of its continuous pan/tilt space


class OnvifHead:
    """The camera behind `onvif://host:port`; `folder` is the rig file's (for a relative
    password file), `password` and `transport` replace the rig's password and the HTTP
    transport (tests), `wall_ns` is the clock of the odometry's stamps."""

    def __init__(
        self,
        servo: OnvifServo,
        *,
        folder: Path | None = None,
        password: str | None = None,
        transport: httpx.BaseTransport | None = None,
        wall_ns: Callable[[], int] = time.time_ns,
    ) -> None:
        self.servo = servo
        self._folder = folder
        self.codec = OnvifTraits()
        self.transport = InstantLine(servo.port)
        self.counters: Counter[str] = Counter()
        self._password = password
        self._http = transport
        self._wall_ns = wall_ns
        self._client: OnvifClient | None = None
        self.profile = ""
        self.pan_space: AxisSpace | None = None
        self.tilt_space: AxisSpace | None = None
        self.capabilities: Capabilities | None = None
        self.zoom_space: tuple[float, float] | None = None  # the absolute zoom space's ends
        self.last_status = "UNKNOWN"
        self._last_zoom: float | None = None
        self._continuous: tuple[float, float, int] | None = None  # fractions, end (ns)

    def __enter__(self) -> OnvifHead:
        self.connect()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.disconnect()

    @property
    def is_connected(self) -> bool:
        return self._client is not None

    # --- connection --------------------------------------------------------------------------

    def _new_client(self, services: dict[str, str] | None) -> OnvifClient:
        password = (
            self._password
            if self._password is not None
            else read_password(self.servo, self._folder)
        )
        return OnvifClient(
            endpoint=OnvifEndpoint(device_url(self.servo), services=services or {}),
            credentials=OnvifCredentials(self.servo.username, password),
            retries=0,
            timeout_s=self.servo.timeout_ms / 1000.0,
            transport=self._http,
        )

    def connect(self) -> None:
        """Discover the services, pick the profile, read the node's spaces (raises `LinkError`,
        `HandshakeError`, `DeviceError`; nothing stays open on failure)."""
        self.disconnect()
        try:
            with self._new_client(None) as probe:
                services = self._guarded(probe.discover_services)
            client = self._new_client(services)
            try:
                self._client = client
                self._read_profile(client)
            except BaseException:
                self.disconnect()
                raise
        except PasswordError as exc:
            raise HandshakeError(str(exc)) from exc

    def _read_profile(self, client: OnvifClient) -> None:
        profiles = self._guarded(client.get_profiles)
        wanted = [p for p in profiles if p.get("ptz")]
        if self.servo.profile is not None:
            wanted = [p for p in wanted if p.get("token") == self.servo.profile]
        if not wanted:
            which = self.servo.profile or "any profile"
            raise HandshakeError(f"{self.servo.port}: no PTZ configuration in {which}")
        profile = wanted[0]
        self.profile = str(profile["token"])
        node_token = profile["ptz"].get("node_token")
        nodes = self._guarded(client.ptz_get_nodes)
        node = next((n for n in nodes if n.get("token") == node_token), nodes[0] if nodes else {})
        ranges: dict[str, Any] = dict(node.get("ranges", {}))
        options = self._guarded(
            lambda: client.ptz_get_configuration_options(
                configuration_token=str(profile["ptz"]["token"])
            )
        )
        ranges.update(options.get("spaces", {}))  # the configuration's own, where it has them
        self._set_spaces(ranges)

    def _set_spaces(self, ranges: dict[str, Any]) -> None:
        absolute = ranges.get("absolute_pan_tilt")
        continuous = ranges.get("continuous_pan_tilt")
        if absolute is None and continuous is None:
            raise HandshakeError(
                f"{self.servo.port}: the PTZ node has neither absolute nor "
                "continuous pan/tilt moves"
            )
        (pan_lo_deg, pan_hi_deg), (tilt_lo_deg, tilt_hi_deg) = (
            self.servo.pan_range_deg,
            self.servo.tilt_range_deg,
        )
        pan_lo, pan_hi = _ends(absolute, "x", -1.0)
        tilt_lo, tilt_hi = _ends(absolute, "y", -1.0)
        self.pan_space = AxisSpace(
            pan_lo, pan_hi, math.radians(pan_lo_deg), math.radians(pan_hi_deg)
        )
        self.tilt_space = AxisSpace(
            tilt_lo, tilt_hi, math.radians(tilt_lo_deg), math.radians(tilt_hi_deg)
        )
        self.capabilities = Capabilities(
            absolute=absolute is not None,
            relative=ranges.get("relative_pan_tilt") is not None,
            continuous=continuous is not None,
            velocity_max=(_ends(continuous, "x", 0.0)[1], _ends(continuous, "y", 0.0)[1]),
        )
        zoom = ranges.get("absolute_zoom")
        self.zoom_space = _ends(zoom, "x", 0.0) if zoom is not None else None

    def disconnect(self) -> None:
        if self._client is not None:
            self._client.close()
            self._client = None

    def stream_uri(self) -> str:
        """The profile's stream URI (GetStreamUri), carrying the credentials."""
        client = self._connected()
        return str(
            self._guarded(
                lambda: client.get_stream_uri(profile_token=self.profile, with_credentials=True)
            )
        )

    # --- requests ----------------------------------------------------------------------------

    def _connected(self) -> OnvifClient:
        if self._client is None:
            raise NotConnectedError(f"{self.servo.port}: used before connect()")
        return self._client

    def _guarded(self, call: Callable[[], Any]) -> Any:
        """Run one onveef call, its failures turned into the link's."""
        try:
            return call()
        except OnvifTimeoutError as exc:
            self.counters["timeouts"] += 1
            raise ServoTimeout(f"{self.servo.port}: {exc}") from exc
        except (OnvifTransportError, OnvifServiceUnavailableError) as exc:
            raise LinkError(f"{self.servo.port}: {exc}") from exc
        except OnvifAuthError as exc:
            raise LinkError(f"{self.servo.port}: credentials refused: {exc}") from exc
        except OnvifError as exc:
            self.counters["device_errors"] += 1
            raise DeviceError(f"{self.servo.port}: {type(exc).__name__}: {exc}") from exc

    def _send(self, operation: str, body: str) -> tuple[str, int]:
        """One PTZ request; its reply and the time halfway through the exchange (ns). Any move
        but a ContinuousMove ends the one running."""
        client = self._connected()
        if operation not in ("ContinuousMove", "GetStatus"):
            self._continuous = None
        sent_ns = self._wall_ns()
        reply = self._guarded(
            lambda: client.call(service="ptz", operation=operation, body_inner=body)
        )
        self.counters[operation] += 1
        return reply, (sent_ns + self._wall_ns()) // 2

    def _spaces(self) -> tuple[AxisSpace, AxisSpace, Capabilities]:
        if self.pan_space is None or self.tilt_space is None or self.capabilities is None:
            raise NotConnectedError(f"{self.servo.port}: used before connect()")
        return self.pan_space, self.tilt_space, self.capabilities

    def set_position(self, pan_rad: float, tilt_rad: float) -> int:
        """AbsoluteMove to device angles; the time the request went out (ns)."""
        pan_space, tilt_space, _ = self._spaces()
        body = onvif_ptz.absolute_move(
            self.profile, pan_space.to_space(pan_rad), tilt_space.to_space(tilt_rad)
        )
        started_ns = self._wall_ns()
        self._send("AbsoluteMove", body)
        return started_ns

    def move_by(self, pan_rad: float, tilt_rad: float) -> int:
        """RelativeMove by device angles (the translation space has the absolute one's scale)."""
        pan_space, tilt_space, _ = self._spaces()
        body = onvif_ptz.relative_move(
            self.profile,
            pan_rad / pan_space.rad_per_unit * _direction(pan_space),
            tilt_rad / tilt_space.rad_per_unit * _direction(tilt_space),
        )
        started_ns = self._wall_ns()
        self._send("RelativeMove", body)
        return started_ns

    def set_speed(self, pan_fraction: float, tilt_fraction: float, timeout_s: float) -> int:
        """ContinuousMove at fractions (-1..1) of the velocity space's ends, signed in device
        angles; the camera stops by itself after `timeout_s`."""
        pan_space, tilt_space, caps = self._spaces()
        body = onvif_ptz.continuous_move(
            self.profile,
            max(-1.0, min(1.0, pan_fraction)) * caps.velocity_max[0] * _direction(pan_space),
            max(-1.0, min(1.0, tilt_fraction)) * caps.velocity_max[1] * _direction(tilt_space),
            timeout_s,
        )
        started_ns = self._wall_ns()
        self._send("ContinuousMove", body)
        moving = pan_fraction != 0.0 or tilt_fraction != 0.0
        end_ns = started_ns + round(timeout_s * 1e9)
        self._continuous = (pan_fraction, tilt_fraction, end_ns) if moving else None
        return started_ns

    def stop(self) -> int:
        started_ns = self._wall_ns()
        self._send("Stop", onvif_ptz.stop(self.profile))
        return started_ns

    def goto_preset(self, preset: str) -> int:
        started_ns = self._wall_ns()
        self._send("GotoPreset", onvif_ptz.goto_preset(self.profile, preset))
        return started_ns

    def set_zoom(self, zoom: float) -> int:
        """AbsoluteMove of the zoom to position `zoom` (0 widest, 1 longest: the ends of the
        absolute zoom space), then the ContinuousMove running, if any, again for what remains
        of its timeout; the time the request went out (ns)."""
        self._spaces()
        if self.zoom_space is None:
            raise DeviceError(f"{self.servo.port}: the PTZ node has no absolute zoom")
        low, high = self.zoom_space
        body = onvif_ptz.absolute_zoom(self.profile, low + min(max(zoom, 0.0), 1.0) * (high - low))
        started_ns, continuous = self._wall_ns(), self._continuous
        self._send("AbsoluteMove", body)
        if continuous is not None:  # some cameras (ipycam) end a ContinuousMove on any move
            pan_fraction, tilt_fraction, end_ns = continuous
            if end_ns > self._wall_ns():
                self.set_speed(pan_fraction, tilt_fraction, (end_ns - self._wall_ns()) / 1e9)
        return started_ns

    def query_zoom(self) -> float:
        """The zoom position (0..1) of the latest GetStatus: the head link reads it right after
        the position, so one request answers both; a GetStatus of its own before any."""
        if self._last_zoom is None:
            self.query_position()
        if self._last_zoom is None or self.zoom_space is None:
            raise DeviceError(f"{self.servo.port}: GetStatus reports no zoom")
        low, high = self.zoom_space
        return min(max((self._last_zoom - low) / (high - low), 0.0), 1.0)

    def query_position(self, between: Callable[[], None] | None = None) -> DevicePosition:
        """GetStatus as device angles, dated halfway through the exchange; `between` is unused
        (one reply)."""
        pan_space, tilt_space, _ = self._spaces()
        reply, t_ns = self._send("GetStatus", onvif_ptz.get_status(self.profile))
        try:
            status = onvif_ptz.parse_status(reply)
        except CodecError:
            self.codec.bad_frames += 1
            raise
        self.last_status = status.move_status
        self._last_zoom = status.zoom
        return DevicePosition(
            pan_space.to_rad(status.pan), tilt_space.to_rad(status.tilt), t_ns, t_ns
        )


def _ends(space: dict[str, Any] | None, axis: str, low: float) -> tuple[float, float]:
    """An axis's range in a space as GetNodes gives it; `low`..1 where it gives none."""
    extent = (space or {}).get(axis)
    if not extent or float(extent["max"]) == float(extent["min"]):
        return low, 1.0
    return float(extent["min"]), float(extent["max"])


def _direction(space: AxisSpace) -> float:
    """+1 where the camera's units grow with the device angle, -1 where they shrink."""
    return 1.0 if (space.high - space.low) * (space.high_rad - space.low_rad) > 0 else -1.0
