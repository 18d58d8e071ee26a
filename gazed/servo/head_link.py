"""The link to the head, as the `servo` process runs it: set-points written, position polled,
the link kept open (DESIGN §8).

Demands become set-points written to the head (`SetpointWriter`: limits, hold on command
timeout, never a set-point behind a whole one still on the line); how full the line is, is
measured (`LineLoadMeter`). Position is polled at `odometry_rate_hz` and dated when the head
read it (`OdometryDating`); a head that cannot report it (Pelco-D without the extended queries)
gets its odometry dead-reckoned from the set-points. The head's response lag is measured from
its position replies (`ResponseLag`). A failed link (port gone, `POLL_FAILURES_FOR_LINK_DOWN`
unanswered polls in a row, a failed handshake) is reported and reopened with exponential
backoff up to `reconnect_max_s`. `close()` drives the head to park, then closes the port.
The digital head (`gazed.servo.digital_head`) stands in for the driver: a head model in this
process.

`step(now)` is the loop body. A step run for a demand in the bus's receive thread
(`now.immediate`) writes it and nothing slow: polls and reconnects (serial exchanges) stay in
the loop's own steps, so a demand arriving meanwhile is still taken between a poll's frames.
Demands are pulled from `demands()`; each fresh demand, as limited, goes to `on_command` the
moment its bytes are written, a poll's end not awaited.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Literal, Protocol

from gazed.backoff import Backoff
from gazed.config import DigitalServo, Rig
from gazed.config.servo import OnvifServo
from gazed.geometry.kinematics import device_from_joint
from gazed.messages import GazeDemand
from gazed.servo import CodecError, HandshakeError, make_codec
from gazed.servo.digital_head import DigitalHead
from gazed.servo.drive_speeds import DriveSpeeds, drive_rates_rad_s
from gazed.servo.driver import DeviceError, ServoDriver, ServoTimeout
from gazed.servo.line_load import LineLoadMeter
from gazed.servo.odometry import JointReading, OdometryDating
from gazed.servo.onvif_driver import onvif_driver
from gazed.servo.onvif_head import OnvifHead
from gazed.servo.park import park
from gazed.servo.response_lag import ResponseLag
from gazed.servo.setpoint_writer import SetpointWriter
from gazed.servo.speed_mode import SpeedHead, speed_head
from gazed.servo.transport import LinkError, Transport
from gazed.servo.visca_ip_transport import open_transport
from gazed.servo.zoom_drive import ZoomDrive

BACKOFF_INITIAL_S = 0.25
STATUS_PERIOD_S = 1.0
POLL_FAILURES_FOR_LINK_DOWN = 3

log = logging.getLogger("gazed.servo")

LinkState = Literal["connected", "connecting", "down"]


class Instant(Protocol):
    """When a step runs (`services.runtime.Now`): wall clock for stamps, monotonic for
    deadlines; `immediate` for a step in the bus's receive thread."""

    @property
    def wall_ns(self) -> int: ...

    @property
    def mono_s(self) -> float: ...

    @property
    def immediate(self) -> bool: ...


@dataclass(frozen=True)
class LinkStatus:
    """The link as `servo/status` reports it, at `t_ns` (wall clock)."""

    t_ns: int
    link: LinkState
    holding: bool
    errors: int
    clamps: int
    refused: int
    reconnects: int
    last_error: str | None
    timeouts: int
    commands: int
    dead_reckoned: bool
    response_lag_s: float | None
    line_load: float | None


@dataclass(frozen=True)
class LinkStep:
    """What a step has to publish, and how long until it wants to run again."""

    odometry: JointReading | None
    status: LinkStatus | None
    wait_s: float


class HeadLink:
    """The head behind the rig's `[servo]` port. `refused_upstream()` counts demands refused
    before they reached the link (malformed on the wire); `transport` replaces the rig's serial
    port (tests); `mono_s`, `wall_ns` and `sleep` are the clocks (`sleep` paces the park)."""

    def __init__(
        self,
        rig: Rig,
        demands: Callable[[], Iterable[GazeDemand]],
        on_command: Callable[[GazeDemand, int], None],
        *,
        refused_upstream: Callable[[], int] = lambda: 0,
        transport: Transport | None = None,
        mono_s: Callable[[], float] = time.monotonic,
        wall_ns: Callable[[], int] = time.time_ns,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        self.head = rig.head
        self.servo = rig.servo
        self._refused_upstream = refused_upstream
        self._mono_s = mono_s
        self._wall_ns = wall_ns
        self._sleep = sleep
        self.driver: ServoDriver | DigitalHead | SpeedHead
        self.zoom: ZoomDrive | None = None
        if isinstance(rig.servo, DigitalServo):  # a model in this process, no serial port
            self.driver = DigitalHead(rig.head, rig.servo, mono_s=mono_s, wall_ns=wall_ns)
            if rig.camera.zoom_focal_px:
                self.zoom = ZoomDrive(self.driver, rig.head.zoom_rate_max_s)
        elif isinstance(rig.servo, OnvifServo):  # an IP camera over HTTP/SOAP
            self.driver = onvif_driver(rig, mono_s=mono_s, wall_ns=wall_ns)
            if rig.camera.zoom_focal_px and isinstance(self.driver.device, OnvifHead):
                self.zoom = ZoomDrive(self.driver.device, rig.head.zoom_rate_max_s)
        else:
            timeout_s = rig.servo.timeout_ms / 1000.0
            self.driver = ServoDriver(
                make_codec(rig.servo.protocol, **rig.servo_params()),
                transport or open_transport(rig.servo.port, rig.servo.baud, timeout_s),
                timeout_s,
                mono_s,
            )
            if rig.camera.zoom_focal_px and self.driver.codec.zooms:
                self.zoom = ZoomDrive(self.driver, rig.head.zoom_rate_max_s)
            if rig.servo.mode == "speed":  # drive commands (VISCA, Pelco-D)
                drives = DriveSpeeds(self.driver, drive_rates_rad_s(rig.servo))
                self.driver = speed_head(rig, drives, mono_s=mono_s, wall_ns=wall_ns)
        self.codec = self.driver.codec
        if rig.camera.zoom_focal_px and self.zoom is None:
            log.warning("[camera] zoom_focal_px: %s does not drive a zoom here", rig.servo.protocol)
        self._demands = demands
        self.writer = SetpointWriter(
            rig.head,
            self.driver,
            self._zoom_demands,
            on_command,
            command_period_s=1.0 / rig.servo.command_rate_hz,
            command_timeout_s=rig.servo.command_timeout_ms / 1000.0,
            t_s=mono_s(),
        )
        self.setpoints = self.writer.setpoints
        if self.zoom is not None:  # the zoom yields its socket to a waiting pan-tilt set-point
            self.writer.make_room = self.zoom.yield_socket
        if isinstance(self.driver, SpeedHead):  # speed mode runs on where they are heading
            self.driver.follow(self.setpoints)
        self.dating = OdometryDating(rig.head, self.codec.pan_wraps)
        self.response_lag = ResponseLag()
        self.line = LineLoadMeter(STATUS_PERIOD_S)
        self.backoff = Backoff(BACKOFF_INITIAL_S, rig.servo.reconnect_max_s)
        self.poll_period_s = 1.0 / rig.servo.odometry_rate_hz

        self.link: LinkState = "connecting"
        self.last_error: str | None = None
        self.counts = {"errors": 0, "timeouts": 0, "reconnects": 0, "odometry": 0}
        self._connected_before = False
        self._next_connect_s = 0.0
        self._next_poll_s = 0.0
        self._next_status_s = 0.0
        self._poll_failures = 0
        self._poll_ms = 0.0
        self._published_state: tuple[str, bool] | None = None

    @property
    def holding(self) -> bool:
        return self.writer.holding

    def _zoom_demands(self) -> list[GazeDemand]:
        """The fresh demands, their zoom taken by the zoom drive on the way."""
        fresh = list(self._demands())
        if self.zoom is not None:
            for demand in fresh:
                self.zoom.demand(demand.zoom)
        return fresh

    # --- the loop --------------------------------------------------------------------------

    def step(self, now: Instant) -> LinkStep:
        odometry = None
        try:
            if not self.driver.is_connected:
                self.writer.take_demands(now.mono_s, executable=False)
                if now.mono_s >= self._next_connect_s and not now.immediate:
                    self._connect(now.mono_s)
            if self.driver.is_connected:
                self.writer.take_demands(now.mono_s, executable=True)
                self.writer.check_hold(now.mono_s)
                self.writer.write(now.mono_s)
                if not now.immediate:
                    if self.zoom is not None:
                        self.zoom.write(now.mono_s)
                    odometry = self._poll(now)
                self.line.measure(now.mono_s, self.driver.transport)
        except LinkError as exc:
            self._link_lost(self._mono_s(), exc)  # the backoff runs from when it failed
        except (DeviceError, CodecError) as exc:
            self.counts["errors"] += 1
            self.last_error = str(exc)
        status = self._status_due(now)
        return LinkStep(odometry, status, self._wait_s(self._mono_s()))  # a poll takes a while

    def _wait_s(self, mono_s: float) -> float:
        times = [self._next_status_s]
        if not self.driver.is_connected:
            times.append(self._next_connect_s)
        else:
            times += [self._next_poll_s, *self.writer.wake_times_s()]
        return max(0.0, min(times) - mono_s)

    def close(self) -> LinkStatus:
        """Drive the head to park, close the port; the status to publish last."""
        preset = getattr(self.servo, "park_preset", None)
        if self.driver.is_connected and preset is not None:
            try:
                self.driver.device.goto_preset(preset)  # type: ignore[union-attr]
            except (LinkError, DeviceError) as exc:
                log.warning("could not go to the park preset %s: %s", preset, exc)
        elif self.driver.is_connected:
            try:
                if self.zoom is not None:
                    self.zoom.driver.set_zoom(0.0)  # parked at the widest view
                park(
                    self.driver,
                    self.setpoints,
                    self.head,
                    self.writer.command_period_s,
                    mono_s=self._mono_s,
                    sleep=self._sleep,
                )
            except (LinkError, DeviceError, CodecError) as exc:
                log.warning("could not park: %s", exc)
        self.driver.disconnect()
        self.link = "down"
        return self._status(self._wall_ns())

    # --- link --------------------------------------------------------------------------------

    def _connect(self, mono_s: float) -> None:
        self.link = "connecting"
        try:
            self.driver.connect()
            if self.zoom is not None:
                self.zoom.reset(self.zoom.read())
            if self.codec.can_report_position:
                pan, tilt = self.dating.joint(self.driver.query_position())
            else:
                pan, tilt = self.writer.start_point(mono_s)
                self.driver.set_position(*device_from_joint(self.head, pan, tilt))
        except (LinkError, HandshakeError, DeviceError, CodecError) as exc:
            self.driver.disconnect()
            self.link = "down"
            self.counts["errors"] += 1
            self.last_error = f"connect: {exc}"
            self._next_connect_s = self._mono_s() + self.backoff.next_delay_s()
            return
        self.writer.reset(pan, tilt, mono_s)
        self.response_lag.reset()
        self.dating.reset()
        self._poll_failures = 0
        self.backoff.reset()
        self._next_poll_s = mono_s
        self.line.reset(mono_s, self.driver.transport)
        self.link = "connected"
        if self._connected_before:
            self.counts["reconnects"] += 1
            log.info("link to %s restored", self.servo.port)
        self._connected_before = True

    def _link_lost(self, mono_s: float, exc: Exception) -> None:
        log.warning("link to %s lost: %s", self.servo.port, exc)
        self.driver.disconnect()
        self.link = "down"
        self.counts["errors"] += 1
        self.last_error = str(exc)
        self._next_connect_s = mono_s + self.backoff.next_delay_s()

    # --- odometry ----------------------------------------------------------------------------

    def _poll(self, now: Instant) -> JointReading | None:
        if now.mono_s < self._next_poll_s:
            return None
        self._next_poll_s = now.mono_s + self.poll_period_s
        if not self.codec.can_report_position:
            pan, tilt = self.setpoints.advance(now.mono_s)
            pan_rate, tilt_rate = self.setpoints.rates_rad_s
            self.counts["odometry"] += 1
            return JointReading(now.wall_ns, pan, tilt, pan_rate, tilt_rate, dead_reckoned=True)
        started = time.perf_counter()
        try:
            position = self.driver.query_position(between=self._between_poll_frames)
            answered_s, answered_ns = self._mono_s(), self._wall_ns()  # the reply was just read
            zoom = self.zoom.read() if self.zoom is not None else None
        except ServoTimeout as exc:
            self.counts["timeouts"] += 1
            self._poll_failures += 1
            self.last_error = str(exc)
            if self._poll_failures >= POLL_FAILURES_FOR_LINK_DOWN:
                raise LinkError(f"{self._poll_failures} position polls unanswered") from exc
            return None
        self._poll_ms = (time.perf_counter() - started) * 1000.0
        self._poll_failures = 0
        reading = dataclasses.replace(self.dating.reading(position), zoom=zoom)
        setpoint = self.setpoints.advance(answered_s - (answered_ns - reading.t_ns) / 1e9)
        self.response_lag.observe(
            setpoint, self.setpoints.rates_rad_s, (reading.pan_rad, reading.tilt_rad)
        )
        self.counts["odometry"] += 1
        return reading

    def _between_poll_frames(self) -> None:
        self.writer.write_fresh(self._mono_s())

    # --- status and health -------------------------------------------------------------------

    @property
    def refused(self) -> int:
        return self.writer.limiter.refused + self._refused_upstream()

    def _status_due(self, now: Instant) -> LinkStatus | None:
        """On every change of link or holding, and once a `STATUS_PERIOD_S`."""
        state = (self.link, self.holding)
        if state == self._published_state and now.mono_s < self._next_status_s:
            return None
        self._next_status_s = now.mono_s + STATUS_PERIOD_S
        return self._status(now.wall_ns)

    def _status(self, t_ns: int) -> LinkStatus:
        self._published_state = (self.link, self.holding)
        return LinkStatus(
            t_ns=t_ns,
            link=self.link,
            holding=self.holding,
            errors=self.counts["errors"],
            clamps=self.writer.limiter.clamps + self.setpoints.clamps,
            refused=self.refused,
            reconnects=self.counts["reconnects"],
            last_error=self.last_error,
            timeouts=self.counts["timeouts"],
            commands=self.writer.counts["commands"],
            dead_reckoned=not self.codec.can_report_position,
            response_lag_s=self.response_lag.lag_s,
            line_load=self.line.load,
        )

    def counters(self) -> dict[str, int]:
        """The link's counters for `servo/health`."""
        limiter = self.writer.limiter
        return {
            **self.counts,
            **self.writer.counts,
            "line_overloaded_s": self.line.overloaded_s,
            "joint_clamps": limiter.joint_clamps,
            "rate_clamps": limiter.rate_clamps,
            "setpoint_clamps": self.setpoints.clamps,
            "response_lag_outliers": self.response_lag.outliers,
            "refused": self.refused,
            "discarded_bytes": self.codec.discarded_bytes,
            "bad_frames": self.codec.bad_frames,
            **{f"driver_{k}": v for k, v in self.driver.counters.items()},
            **{f"link_{k}": v for k, v in self.driver.transport.counters.items()},
        }

    def notes(self) -> dict[str, str]:
        notes = {"link": self.link, "holding": str(self.holding)}
        if self.last_error:
            notes["last_error"] = self.last_error
        if self.line.load is not None:
            notes["line_load"] = f"{self.line.load:.0%}"
        return notes

    def stage_ms(self) -> dict[str, float]:
        """How long the last set-point took to write and the last poll to answer."""
        stage_ms = {"write": self.writer.write_ms, "poll": self._poll_ms}
        if self.response_lag.lag_s is not None:
            stage_ms["head_response_lag"] = round(self.response_lag.lag_s * 1e3, 2)
        return stage_ms
