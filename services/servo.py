"""The `servo` process: the serial link to the head (DESIGN §8; seed 000 §2, Fig. 1 — the servo
controller that takes angular demands and propagates odometry).

Inputs: `gaze/demand` (joint angles and rates).
Outputs: `servo/odometry` (joint angles, rates, the time the reply was read),
`servo/command` (each fresh demand as written, limited, its stamps ending `("servo", t)` when
its bytes were written) and `servo/status` (link state, holding, errors, clamps, refusals,
reconnects, the head's response lag — how late it follows the set-points, from its position
replies, `gazed.servo.response_lag`; how full the serial line was over the last second; on
every change and once a second).
Settings: [head] signs, zero offsets, joint, rate and acceleration limits, park angles; [servo]
protocol and its keys, port, baud, timeout_ms, command_timeout_ms, odometry_rate_hz,
command_rate_hz, reconnect_max_s.

Every demand is limited (`DemandLimiter`: non-finite refused, joint limits — brought in by one
device unit, so rounding never crosses them — and rate limits clamped, all counted) and
becomes the target of the set-point generator, whose set-points — never a jump — are written at
once for a fresh demand and at `command_rate_hz` while a move is under way — but not behind a
whole set-point still waiting for the serial line (the newest then replaces it, counted as
`held_for_the_line`). A line busier than `LINE_LOAD_WARN` of a second is warned about and
counted (`line_overloaded_s`): its rates ask more than its baud rate carries.
No fresh demand within `command_timeout_ms` -> hold (decelerate to rest). Position is polled at
`odometry_rate_hz` and dated when the head read it (each axis by its own reply); a head that
cannot report it (Pelco-D without the extended queries) gets its odometry dead-reckoned from
the set-points, marked `dead_reckoned`. A failed link (port gone, three unanswered polls in a
row, a failed handshake) is reported and reopened with exponential backoff up to
`reconnect_max_s`. On SIGTERM the head is driven to park, then the port closed.
"""

from __future__ import annotations

import logging
import math
import time

from gazed.bus import Bus
from gazed.config import Rig
from gazed.geometry.kinematics import device_from_joint, joint_from_device
from gazed.messages import GazeDemand, Odometry, ServoStatus
from gazed.servo import CodecError, HandshakeError, make_codec
from gazed.servo.driver import DeviceError, DevicePosition, ServoDriver, ServoTimeout
from gazed.servo.limits import DemandLimiter, Target
from gazed.servo.response_lag import ResponseLag
from gazed.servo.setpoints import SetpointGenerator
from gazed.servo.transport import LinkError, SerialTransport
from gazed.topics import GAZE_DEMAND, SERVO_COMMAND, SERVO_ODOMETRY, SERVO_STATUS
from services.runtime import HealthReport, Now, main

BACKOFF_INITIAL_S = 0.25
STATUS_PERIOD_S = 1.0
POLL_FAILURES_FOR_LINK_DOWN = 3
PARK_TIMEOUT_S = 2.5
LINE_LOAD_WARN = 0.95  # share of a second on the line past which it is full: set-points wait
STAGE = "servo"

log = logging.getLogger("gazed.servo")


def _rate(change_rad: float, dt_ns: int) -> float:
    return change_rad / (dt_ns / 1e9) if dt_ns > 0 else 0.0


def wrap_angle(angle_rad: float) -> float:
    """Into (-π, π]."""
    wrapped = math.remainder(angle_rad, 2.0 * math.pi)
    return math.pi if wrapped == -math.pi else wrapped


class ServoService:
    """Demands in, set-points out, odometry and status published; `step(now)` is the loop body."""

    def __init__(self, rig: Rig, bus: Bus) -> None:
        self.rig = rig
        self.head = rig.head
        self.servo = rig.servo
        self.bus = bus
        self.codec = make_codec(rig.servo.protocol, **rig.servo_params())
        self.driver = ServoDriver(
            self.codec,
            SerialTransport(rig.servo.port, rig.servo.baud),
            rig.servo.timeout_ms / 1000.0,
        )
        inset_rad = self.codec.resolution_rad
        self.limiter = DemandLimiter(rig.head, inset_rad)
        self.setpoints = SetpointGenerator(rig.head, time.monotonic(), inset_rad)
        self.response_lag = ResponseLag()
        self.demands = bus.subscribe(GAZE_DEMAND, capacity=64, immediate=True)
        self.odometry = bus.publisher(SERVO_ODOMETRY)
        self.status = bus.publisher(SERVO_STATUS)
        self.commands = bus.publisher(SERVO_COMMAND)
        self.command_period_s = 1.0 / rig.servo.command_rate_hz
        self.poll_period_s = 1.0 / rig.servo.odometry_rate_hz
        self.command_timeout_s = rig.servo.command_timeout_ms / 1000.0

        self.link: str = "connecting"
        self.holding = True
        self.last_error: str | None = None
        self.counts = {
            "errors": 0,
            "timeouts": 0,
            "reconnects": 0,
            "commands": 0,
            "odometry": 0,
            "demands": 0,
            "held_for_the_line": 0,
            "line_overloaded_s": 0,
        }
        self._connected_before = False
        self._backoff_s = BACKOFF_INITIAL_S
        self._next_connect_s = 0.0
        self._next_poll_s = 0.0
        self._next_command_s = 0.0
        self._next_status_s = 0.0
        self._last_demand_s: float | None = None
        self._poll_failures = 0
        self._written: tuple[float, float] | None = None
        self._fresh: tuple[GazeDemand, Target] | None = None
        self._last_reading: tuple[float, float, int, int] | None = None
        self._write_ms = 0.0
        self._setpoint_line_s = 0.0  # how long the last set-point's bytes took on the line
        self._poll_ms = 0.0
        self._published_state: tuple[str, bool] | None = None
        self.line_load: float | None = None
        self._line_mark = (0.0, 0.0)  # (monotonic s, transport.line_s) at the last measurement

    # --- the loop --------------------------------------------------------------------------

    def step(self, now: Now) -> float:
        try:
            # a step for a demand, in the bus's receive thread, writes it and nothing slow: the
            # polls and reconnects (serial exchanges) stay in the loop's own steps, so a demand
            # arriving meanwhile is still taken between a poll's frames
            if not self.driver.is_connected:
                self._take_demands(now, executable=False)
                if now.mono_s >= self._next_connect_s and not now.immediate:
                    self._connect(now)
            if self.driver.is_connected:
                self._take_demands(now, executable=True)
                self._check_hold(now)
                self._command(now)
                if not now.immediate:
                    self._poll(now)
                self._measure_line(now)
        except LinkError as exc:
            self._link_lost(now, exc)
        except (DeviceError, CodecError) as exc:
            self.counts["errors"] += 1
            self.last_error = str(exc)
        self._publish_status(now)
        return self._wait_s(time.monotonic())  # not `now`: a poll may have taken a while

    def _wait_s(self, mono_s: float) -> float:
        times = [self._next_status_s]
        if not self.driver.is_connected:
            times.append(self._next_connect_s)
        else:
            times.append(self._next_poll_s)
            if not self.setpoints.settled or self._fresh is not None:
                times.append(self._next_command_s)
            if not self.holding and self._last_demand_s is not None:
                times.append(self._last_demand_s + self.command_timeout_s)
        return max(0.0, min(times) - mono_s)

    # --- link --------------------------------------------------------------------------------

    def _connect(self, now: Now) -> None:
        self.link = "connecting"
        try:
            self.driver.connect()
            if self.codec.can_report_position:
                pan, tilt = self._joint(self.driver.query_position())
            else:
                pan, tilt = (
                    self.setpoints.advance(now.mono_s) if self._written else self.head.park_rad
                )
                self.driver.set_position(*device_from_joint(self.head, pan, tilt))
        except (LinkError, HandshakeError, DeviceError, CodecError) as exc:
            self.driver.disconnect()
            self.link = "down"
            self.counts["errors"] += 1
            self.last_error = f"connect: {exc}"
            self._next_connect_s = now.mono_s + self._backoff_s
            self._backoff_s = min(2.0 * self._backoff_s, self.servo.reconnect_max_s)
            return
        self.setpoints.reset(pan, tilt, now.mono_s)
        self.response_lag.reset()
        self._written = (pan, tilt)
        self.holding = True
        self._last_demand_s = None
        self._fresh = None
        self._last_reading = None
        self._poll_failures = 0
        self._backoff_s = BACKOFF_INITIAL_S
        self._next_poll_s = now.mono_s
        self._line_mark = (now.mono_s, self.driver.transport.line_s)
        self.line_load = None
        self.link = "connected"
        if self._connected_before:
            self.counts["reconnects"] += 1
            log.info("link to %s restored", self.servo.port)
        self._connected_before = True

    def _link_lost(self, now: Now, exc: Exception) -> None:
        log.warning("link to %s lost: %s", self.servo.port, exc)
        self.driver.disconnect()
        self.link = "down"
        self.counts["errors"] += 1
        self.last_error = str(exc)
        self._next_connect_s = now.mono_s + self._backoff_s
        self._backoff_s = min(2.0 * self._backoff_s, self.servo.reconnect_max_s)

    # --- demands and set-points --------------------------------------------------------------

    def _take_demands(self, now: Now, executable: bool) -> None:
        latest: tuple[GazeDemand, Target] | None = None
        for demand in self.demands.take():
            self.counts["demands"] += 1
            target = self.limiter.limit(demand)
            if target is not None:
                latest = (demand, target)
        if latest is None or not executable:
            return
        demand, target = latest
        self.setpoints.track(target, now.mono_s)
        self._last_demand_s = now.mono_s
        self._fresh = (demand, target)
        self._next_command_s = now.mono_s
        self.holding = False

    def _check_hold(self, now: Now) -> None:
        if self.holding or self._last_demand_s is None:
            return
        if now.mono_s - self._last_demand_s > self.command_timeout_s:
            self.setpoints.hold(now.mono_s)
            self.holding = True
            self._next_command_s = now.mono_s

    def _command(self, now: Now) -> None:
        if now.mono_s < self._next_command_s:
            return
        # a set-point may queue behind the one on the line, not behind a whole one more: on a
        # line that cannot carry them all, the newest replaces those not yet sent
        waiting_s = self.driver.transport.line_busy_s() - self._setpoint_line_s
        if waiting_s > 0:
            self._next_command_s = now.mono_s + waiting_s
            self.counts["held_for_the_line"] += 1
            return
        setpoint = self.setpoints.advance(now.mono_s)
        if setpoint == self._written and self._fresh is None:
            self._next_command_s = now.mono_s + self.command_period_s
            return
        started = time.perf_counter()
        busy_before_s = self.driver.transport.line_busy_s()
        t_ns = self.driver.set_position(*device_from_joint(self.head, *setpoint))
        self._write_ms = (time.perf_counter() - started) * 1000.0
        self._setpoint_line_s = max(0.0, self.driver.transport.line_busy_s() - busy_before_s)
        self._written = setpoint
        self.counts["commands"] += 1
        if self._fresh is not None:
            demand, target = self._fresh
            written = demand.model_copy(
                update={
                    "pan_rad": target.pan_rad,
                    "tilt_rad": target.tilt_rad,
                    "pan_rate_rad_s": target.pan_rate_rad_s,
                    "tilt_rate_rad_s": target.tilt_rate_rad_s,
                }
            )
            self.commands.put(written.stamped(STAGE, t_ns))
            self._fresh = None
        self._next_command_s = now.mono_s + self.command_period_s

    def _between_poll_frames(self) -> None:
        """A demand that came while the head was answering a poll goes out now, not after the
        whole poll (Pelco-D asks pan and tilt in two exchanges)."""
        now = Now.read()
        self._take_demands(now, executable=True)
        if self._fresh is not None:
            self._command(now)

    # --- odometry ----------------------------------------------------------------------------

    def _joint(self, position: DevicePosition) -> tuple[float, float]:
        pan, tilt = joint_from_device(self.head, position.pan_rad, position.tilt_rad)
        return (wrap_angle(pan) if self.codec.pan_wraps else pan), tilt

    def _poll(self, now: Now) -> None:
        if now.mono_s < self._next_poll_s:
            return
        self._next_poll_s = now.mono_s + self.poll_period_s
        if not self.codec.can_report_position:
            pan, tilt = self.setpoints.advance(now.mono_s)
            pan_rate, tilt_rate = self.setpoints.rates_rad_s
            self._publish_odometry(now.wall_ns, pan, tilt, pan_rate, tilt_rate, dead=True)
            return
        started = time.perf_counter()
        try:
            position = self.driver.query_position(between=self._between_poll_frames)
            answered_s, answered_ns = time.monotonic(), time.time_ns()  # the reply was just read
        except ServoTimeout as exc:
            self.counts["timeouts"] += 1
            self._poll_failures += 1
            self.last_error = str(exc)
            if self._poll_failures >= POLL_FAILURES_FOR_LINK_DOWN:
                raise LinkError(f"{self._poll_failures} position polls unanswered") from exc
            return
        self._poll_ms = (time.perf_counter() - started) * 1000.0
        self._poll_failures = 0
        pan, tilt = self._joint(position)
        reading = (pan, tilt, position.t_pan_ns, position.t_tilt_ns)
        pan_rate = tilt_rate = 0.0
        if self._last_reading is not None:
            last_pan, last_tilt, last_pan_ns, last_tilt_ns = self._last_reading
            pan_rate = _rate(wrap_angle(pan - last_pan), position.t_pan_ns - last_pan_ns)
            tilt_rate = _rate(tilt - last_tilt, position.t_tilt_ns - last_tilt_ns)
        self._last_reading = reading
        # both axes at the later of their two instants (Pelco-D and PTU read them one by one)
        t_ns = max(position.t_pan_ns, position.t_tilt_ns)
        pan += pan_rate * (t_ns - position.t_pan_ns) / 1e9
        tilt += tilt_rate * (t_ns - position.t_tilt_ns) / 1e9
        setpoint = self.setpoints.advance(answered_s - (answered_ns - t_ns) / 1e9)
        self.response_lag.observe(setpoint, self.setpoints.rates_rad_s, (pan, tilt))
        self._publish_odometry(t_ns, pan, tilt, pan_rate, tilt_rate, dead=False)

    def _publish_odometry(
        self, t_ns: int, pan: float, tilt: float, pan_rate: float, tilt_rate: float, dead: bool
    ) -> None:
        self.odometry.put(
            Odometry(
                t_capture_ns=t_ns,
                stamps=((STAGE, t_ns),),
                pan_rad=pan,
                tilt_rad=tilt,
                pan_rate_rad_s=pan_rate,
                tilt_rate_rad_s=tilt_rate,
                dead_reckoned=dead,
            )
        )
        self.counts["odometry"] += 1

    # --- the line ----------------------------------------------------------------------------

    def _measure_line(self, now: Now) -> None:
        """Once a second: the share of it the line carried bytes; a warning when it turns
        nearly full (the rates ask more than the baud rate carries)."""
        mark_s, mark_line_s = self._line_mark
        elapsed_s = now.mono_s - mark_s
        if elapsed_s < STATUS_PERIOD_S:
            return
        transport = self.driver.transport
        self._line_mark = (now.mono_s, transport.line_s)
        if transport.byte_time_s == 0.0:
            return
        load = (transport.line_s - mark_line_s) / elapsed_s
        overloaded = load > LINE_LOAD_WARN
        if overloaded:
            self.counts["line_overloaded_s"] += 1
            if self.line_load is None or self.line_load <= LINE_LOAD_WARN:
                log.warning(
                    "the line to %s at %d baud was %.0f%% busy over the last second: "
                    "set-points wait for it and replies come late; lower odometry_rate_hz "
                    "or command_rate_hz, or raise the baud rate",
                    self.servo.port,
                    transport.baud,
                    100.0 * load,
                )
        self.line_load = load

    # --- status and health -------------------------------------------------------------------

    @property
    def refused(self) -> int:
        malformed = self.bus.stats.snapshot()[0].get(f"malformed:{GAZE_DEMAND.suffix}", 0)
        return self.limiter.refused + malformed

    def _publish_status(self, now: Now) -> None:
        state = (self.link, self.holding)
        if state == self._published_state and now.mono_s < self._next_status_s:
            return
        self._published_state = state
        self._next_status_s = now.mono_s + STATUS_PERIOD_S
        self.status.put(
            ServoStatus(
                t_capture_ns=now.wall_ns,
                protocol=self.servo.protocol,
                port=self.servo.port,
                link=self.link,  # type: ignore[arg-type]
                holding=self.holding,
                errors=self.counts["errors"],
                clamps=self.limiter.clamps + self.setpoints.clamps,
                refused=self.refused,
                reconnects=self.counts["reconnects"],
                last_error=self.last_error,
                timeouts=self.counts["timeouts"],
                commands=self.counts["commands"],
                dead_reckoned=not self.codec.can_report_position,
                response_lag_s=self.response_lag.lag_s,
                line_load=self.line_load,
            )
        )

    def health(self) -> HealthReport:
        counters = dict(self.counts)
        counters.update(
            joint_clamps=self.limiter.joint_clamps,
            rate_clamps=self.limiter.rate_clamps,
            setpoint_clamps=self.setpoints.clamps,
            response_lag_outliers=self.response_lag.outliers,
            refused=self.refused,
            discarded_bytes=self.codec.discarded_bytes,
            bad_frames=self.codec.bad_frames,
            **{f"driver_{k}": v for k, v in self.driver.counters.items()},
        )
        notes = {"link": self.link, "holding": str(self.holding)}
        if self.last_error:
            notes["last_error"] = self.last_error
        if self.line_load is not None:
            notes["line_load"] = f"{self.line_load:.0%}"
        stage_ms = {"write": self._write_ms, "poll": self._poll_ms}
        if self.response_lag.lag_s is not None:
            stage_ms["head_response_lag"] = round(self.response_lag.lag_s * 1e3, 2)
        return HealthReport(counters=counters, stage_ms=stage_ms, notes=notes)

    def close(self) -> None:
        """Drive the head to park (set-points at the limits, at most `PARK_TIMEOUT_S`), then
        close the port."""
        if self.driver.is_connected:
            try:
                self._park()
            except (LinkError, DeviceError, CodecError) as exc:
                log.warning("could not park: %s", exc)
        self.driver.disconnect()
        self.link = "down"
        self._published_state = None
        self._publish_status(Now.read())

    def _park(self) -> None:
        park_pan, park_tilt = self.head.park_rad
        self.setpoints.track(Target("park", park_pan, park_tilt, 0.0, 0.0), time.monotonic())
        deadline_s = time.monotonic() + PARK_TIMEOUT_S
        while True:
            setpoint = self.setpoints.advance(time.monotonic())
            self.driver.set_position(*device_from_joint(self.head, *setpoint))
            if self.setpoints.settled or time.monotonic() > deadline_s:
                break
            time.sleep(self.command_period_s)


def build(rig: Rig, bus: Bus) -> ServoService:
    return ServoService(rig, bus)


if __name__ == "__main__":
    raise SystemExit(main("servo", build))
