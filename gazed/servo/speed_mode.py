"""Speed mode: a head driven by speed commands (ONVIF ContinuousMove, VISCA Pan-tiltDrive,
Pelco-D drives) follows the same set-points as a head driven by position.

The head is predicted by a model of the device: its last position reading moved on at each rate
it was told, from `latency_s` after the command was sent, reached at the `[head]` acceleration
limit. The set-points are known ahead from the generator that makes them (`follow`; without one,
extrapolated from the last three written). Each set-point the writer sends, and each poll of the
position, then sets the rate: the set-points' own rate (the demand's feed-forward, as the
set-point generator shapes it) plus the gap between the set-point and the predicted head at the
moment a command sent now would act, closed over the horizon (the time until the loop can next
change the step, longer on a busy host, plus the latency: the gain of a dead-beat loop on the
prediction, kept stable on a head slower to act than the rig says). The closing rate is no more
than the head gains or sheds in a horizon. The rate is then

- capped, on the way to a joint limit, to what the head can still brake from before it
  (sqrt(2·a·d) over the distance left once it has run one poll period at its present rate), and
  zero at or past the limit: the head never runs out of its limits; likewise capped to what it
  can brake from before where the set-points would come to rest (at the rate's change they
  brake at, `setpoint_trend`), so it never runs past them when they stop;
- quantised to the device's speed steps (`speed_steps`, a table of rates per step), never to a
  step faster than the cap. The model runs on the step sent, so the quantisation's error is
  in the next gap and closed with it: the head dithers between the two steps around the
  set-points' rate and stays within a step's travel over the horizon of them;
- sent only when a step changes, or again before the device's own timeout runs out, and at
  most once a command period (`command_rate_hz`; a VISCA camera holds a socket per drive until
  it acts on it); Stop is never held back.

The hold is the writer's: no demand within the command timeout, and the set-points decelerate
to rest, which the head follows until its rate rounds to no step, when it is told Stop. A
set-point older than the command timeout is a target standing still (its rate is dropped).
Every speed command carries the command timeout as the device's own (ONVIF's ContinuousMove
Timeout), so a head whose servo process stalls stops by itself; a running command is renewed
before half of it has passed.
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Callable
from typing import Protocol

from gazed.config import HeadSection, Rig
from gazed.servo.codec import CodecError
from gazed.servo.drive_model import DriveModel, Pair
from gazed.servo.driver import DeviceError, DevicePosition
from gazed.servo.setpoint_trend import planned, run_on, set_point_rates
from gazed.servo.setpoints import SetpointGenerator
from gazed.servo.speed_steps import SpeedSteps, rig_speed_steps
from gazed.servo.transport import LinkError
from gazed.sim.head_mechanics import device_bounds

GAP_MEMORY_S = 1.0  # how long a long gap between the loop's looks at the head is remembered


class SpeedDevice(Protocol):
    """A head that takes speed commands as fractions of its fastest step (ONVIF head)."""

    codec: object
    transport: object
    counters: object

    @property
    def is_connected(self) -> bool: ...

    def connect(self) -> None: ...

    def disconnect(self) -> None: ...

    def set_speed(self, pan_fraction: float, tilt_fraction: float, timeout_s: float) -> int: ...

    def stop(self) -> int: ...

    def set_position(self, pan_rad: float, tilt_rad: float) -> int: ...

    def query_position(self, between: Callable[[], None] | None = None) -> DevicePosition: ...


class SpeedHead:
    """`device` driven by speed towards the set-points written to it, inside `head`'s limits
    (device angles), when `by_speed(device)` says so once it is connected (otherwise the
    set-points go to it as positions); `latency_s` is how long the device takes to act on a
    speed command; `mono_s` and `wall_ns` are the clocks."""

    def __init__(
        self,
        device: SpeedDevice,
        head: HeadSection,
        steps: tuple[SpeedSteps, SpeedSteps],
        *,
        latency_s: float,
        command_timeout_s: float,
        poll_period_s: float,
        command_period_s: float = 0.0,
        mono_s: Callable[[], float] = time.monotonic,
        wall_ns: Callable[[], int] = time.time_ns,
        by_speed: Callable[[SpeedDevice], bool] = lambda _device: True,
    ) -> None:
        self.device = device
        self._by_speed = by_speed
        self.by_speed = True
        self.codec = device.codec
        self.transport = device.transport
        self.counters = device.counters
        self.steps = steps
        self.latency_s = latency_s
        self.command_timeout_s = command_timeout_s
        self.poll_period_s = poll_period_s
        self.command_period_s = command_period_s
        # the loop's period: a command period, and no less than a poll period (the readings
        # close the loop); `_gap_s` is the longest recent time between its looks at the head
        self._period_s = self._gap_s = max(command_period_s, poll_period_s)
        self._decided_s: float | None = None
        self._mono_s = mono_s
        self._wall_ns = wall_ns
        self._head = head
        self._bounds = device_bounds(head)
        self._setpoints: SetpointGenerator | None = None  # the set-points' generator, if known
        self._accel_rad_s2 = head.accel_max_rad_s2
        self._rate_max_rad_s = head.rate_max_rad_s
        self.sent: tuple[int, int] = (0, 0)
        self._sent_s = -math.inf
        self._setpoint: tuple[Pair, Pair, Pair, float] | None = None  # at, rates, accels, when
        self._middle: tuple[Pair, float] | None = None  # the last interval's rates, length
        self._reading: tuple[float, float, float] | None = None  # where, from when (mono s)
        # the device model: the rates told, run on from the last reading
        self.model = DriveModel(latency_s, self._accel_rad_s2, mono_s())
        self.stopped = True

    @property
    def is_connected(self) -> bool:
        return self.device.is_connected

    def connect(self) -> None:
        self.device.connect()
        self.by_speed = self._by_speed(self.device)
        self.sent, self._sent_s, self._setpoint, self._reading = (0, 0), -math.inf, None, None
        self._middle, self._decided_s, self._gap_s = None, None, self._period_s
        self.model = DriveModel(self.latency_s, self._accel_rad_s2, self._mono_s())
        self.stopped = True

    def disconnect(self) -> None:
        """Stop a head still running on a speed command (if it still answers), then close."""
        if self.by_speed and not self.stopped and self.device.is_connected:
            with contextlib.suppress(LinkError, DeviceError, CodecError):
                self.device.stop()
            self.stopped = True
        self.device.disconnect()

    # --- the driver's calls ------------------------------------------------------------------

    def set_position(self, pan_rad: float, tilt_rad: float) -> int:
        """A set-point (device angles): the rate towards it, sent as speed steps; when the
        command went out (or now, where the one running stands)."""
        if not self.by_speed:
            return self.device.set_position(pan_rad, tilt_rad)
        now_s = self._mono_s()
        rates, accels, middle = (0.0, 0.0), (0.0, 0.0), None
        if self._setpoint is not None:
            last, _, _, last_s = self._setpoint
            dt_s = now_s - last_s
            if 0.0 < dt_s <= self.command_timeout_s:
                rates, accels, middle_rates = set_point_rates(
                    (pan_rad, tilt_rad), last, dt_s, self._middle
                )
                middle = (middle_rates, dt_s)
        self._setpoint = ((pan_rad, tilt_rad), rates, accels, now_s)
        self._middle = middle
        return self._command(now_s) or self._wall_ns()

    def query_position(self, between: Callable[[], None] | None = None) -> DevicePosition:
        """The device's position, and the loop closed again on it."""
        position = self.device.query_position(between)
        if not self.by_speed:
            return position
        now_s = self._mono_s()
        read_s = now_s - max(0.0, (self._wall_ns() - position.t_pan_ns) / 1e9)
        read_s = self.model.read(read_s)
        self._reading = (position.pan_rad, position.tilt_rad, read_s)
        if self._setpoint is not None:
            self._command(now_s)
        return position

    def stop(self) -> int:
        t_ns = self.device.stop()
        now_s = self._mono_s()
        self.model.tell(now_s, 0.0, 0.0)
        self.sent, self._sent_s, self.stopped = (0, 0), now_s, True
        self._setpoint = self._middle = None
        return t_ns

    # --- the law -----------------------------------------------------------------------------

    @property
    def horizon_s(self) -> float:
        """Over how long a gap is closed: the step runs until the loop can next change it (its
        period, or longer if it has lately looked at the head less often: a busy host), and a
        reading shows it a latency after it was sent; with the latency in, the loop stays
        stable on a head whose latency is several times the rig's."""
        return max(self._period_s, self._gap_s) + self.latency_s

    def _looked(self, now_s: float) -> None:
        """The loop looks at the head now: a longer gap since the last look counts at once, a
        shorter one lets the gap counted fade back to the period over `GAP_MEMORY_S`."""
        if self._decided_s is not None:
            fade = math.exp(-(now_s - self._decided_s) / GAP_MEMORY_S)
            self._gap_s = max(now_s - self._decided_s, self._gap_s * fade)
        self._decided_s = now_s

    def rates_rad_s(self, now_s: float) -> tuple[float, float]:
        """The rate each axis is to run at from when a command sent now acts (before
        quantisation): the set-points' rate, plus what closes the gap the head is predicted
        to have then within the horizon (the gain a dead-beat loop on the prediction has), but
        no more than the head can gain or shed within a horizon at its acceleration limit, so
        that a large gap never runs it faster than it can brake."""
        feed_forward, error = self._feed_forward_and_error(now_s)
        rates = []
        for axis in (0, 1):
            most_rad_s = self._accel_rad_s2[axis] * self.horizon_s  # gained or shed in a horizon
            closing = max(-most_rad_s, min(most_rad_s, error[axis] / self.horizon_s))
            rates.append(feed_forward[axis] + closing)
        return rates[0], rates[1]

    def _feed_forward_and_error(self, now_s: float) -> tuple[Pair, Pair]:
        """The set-points' rates, and how far the head will be from them when a command sent
        now acts."""
        acts_s = now_s + self.latency_s
        (pan_sp, tilt_sp), rates = self._set_point_at(acts_s, now_s)
        pan_at, tilt_at = self.where(acts_s)
        return rates, (pan_sp - pan_at, tilt_sp - tilt_at)

    def follow(self, setpoints: SetpointGenerator) -> None:
        """Take the set-points' future from the generator that makes them (the head link's):
        where they will be when a command acts is then known, not extrapolated from the last
        ones written, which on a busy host may be far apart."""
        self._setpoints = setpoints

    def _set_point_at(self, t_s: float, now_s: float) -> tuple[Pair, Pair]:
        """The set-point at `t_s` and its rates: as the generator plans them; without one, the
        last moved on at the set-points' rates over their last interval (their rates' change
        carries the demands' noise, which the gap's closing corrects anyway), and a set-point
        older than the command timeout standing still."""
        if self._setpoints is not None:
            return planned(self._setpoints, self._head, t_s)[:2]
        assert self._setpoint is not None
        (pan, tilt), _, _, set_s = self._setpoint
        rates = self._middle[0] if self._middle is not None else (0.0, 0.0)
        if now_s - set_s > self.command_timeout_s:  # the set-points have stopped coming
            rates = (0.0, 0.0)
        ahead_s = t_s - set_s
        return (pan + rates[0] * ahead_s, tilt + rates[1] * ahead_s), rates

    def _set_point_then(self, now_s: float) -> tuple[Pair, Pair, Pair]:
        """The set-points, their rates and rates' change when a command sent now acts, for
        where they could come to rest: as the generator plans them; without one, moved on at
        their rate and its change until the rate reaches rest or the head's limit, and a
        set-point older than the command timeout standing still."""
        if self._setpoints is not None:
            return planned(self._setpoints, self._head, now_s + self.latency_s)
        assert self._setpoint is not None
        set_point, rates, accels, set_s = self._setpoint
        if now_s - set_s > self.command_timeout_s:  # the set-points have stopped coming
            return set_point, (0.0, 0.0), (0.0, 0.0)
        ahead_s = now_s + self.latency_s - set_s
        moved = [
            run_on(set_point[axis], rates[axis], accels[axis], self._rate_max_rad_s[axis], ahead_s)
            for axis in (0, 1)
        ]
        return (moved[0][0], moved[1][0]), (moved[0][1], moved[1][1]), (moved[0][2], moved[1][2])

    def where(self, t_s: float) -> tuple[float, float]:
        """Where the head is at `t_s`: its last reading moved on as the device model runs; on
        its set-points while it has not been read (a head that reports no position)."""
        if self._reading is None:
            return self._set_point_at(t_s, self._mono_s())[0]
        (pan_moved, tilt_moved), _, _ = self.model.run(t_s)
        return self._reading[0] + pan_moved, self._reading[1] + tilt_moved

    def cap_rad_s(self, axis: int, position_rad: float, rate_rad_s: float) -> float:
        """The fastest the axis may run in the direction of `rate_rad_s` from `position_rad`
        and still stop inside its limits."""
        lower, upper = self._bounds[axis]
        room_rad = upper - position_rad if rate_rad_s > 0 else position_rad - lower
        room_rad -= abs(rate_rad_s) * self.poll_period_s
        if room_rad <= 0.0:
            return 0.0
        return math.sqrt(2.0 * self._accel_rad_s2[axis] * room_rad)

    def _braking_caps_rad_s(self, now_s: float, at: Pair, rates: Pair) -> Pair:
        """The fastest each axis may run at `rates` from `at` (when a command sent now acts)
        towards where the set-points could come to rest (braking as they do, or at the head's
        acceleration limit) and still brake there; if they are braking, after the step has
        run until the loop can next change it."""
        set_point, sp_rates, sp_accels = self._set_point_then(now_s)
        caps = []
        for axis in (0, 1):
            rate, accel = sp_rates[axis], sp_accels[axis]
            braking = accel * rate < 0.0
            head_accel = self._accel_rad_s2[axis]
            stop = set_point[axis] + rate * abs(rate) / (
                2.0 * (abs(accel) if braking else head_accel)
            )
            gap_rad = stop - at[axis]
            if gap_rad * rates[axis] <= 0.0:
                caps.append(math.inf)  # running away from it
                continue
            reaction = head_accel * (self.horizon_s - self.latency_s) if braking else 0.0
            caps.append(math.sqrt(reaction * reaction + 2.0 * head_accel * abs(gap_rad)) - reaction)
        return caps[0], caps[1]

    def _command(self, now_s: float) -> int:
        """Send the steps due now, if they differ from those running or are to be renewed;
        when they went out (ns), 0 if nothing was sent. A command is dated halfway through
        its exchange with the device."""
        self._looked(now_s)
        position = self.where(now_s + self.latency_s)
        rates = self.rates_rad_s(now_s)
        braking_caps = self._braking_caps_rad_s(now_s, position, rates)
        wanted = tuple(
            self.steps[axis].quantise(
                rates[axis],
                min(self.cap_rad_s(axis, position[axis], rates[axis]), braking_caps[axis]),
            )
            for axis in (0, 1)
        )
        pan_step, tilt_step = wanted
        if wanted == (0, 0):
            if self.stopped:
                return 0
            t_ns = self.device.stop()
            self.model.tell((now_s + self._mono_s()) / 2.0, 0.0, 0.0)
            self.sent, self._sent_s, self.stopped = (0, 0), now_s, True
            return t_ns
        since_s = now_s - self._sent_s
        if wanted == self.sent and since_s <= self.command_timeout_s / 2.0:
            return 0
        if since_s < self.command_period_s:  # at most one a command period (VISCA's sockets)
            return 0
        t_ns = self.device.set_speed(
            pan_step / self.steps[0].count,
            tilt_step / self.steps[1].count,
            self.command_timeout_s,
        )
        self.model.tell(
            (now_s + self._mono_s()) / 2.0,
            self.steps[0].rate_rad_s(pan_step),
            self.steps[1].rate_rad_s(tilt_step),
        )
        self.sent, self._sent_s, self.stopped = (pan_step, tilt_step), now_s, False
        return t_ns


def speed_head(
    rig: Rig,
    device: SpeedDevice,
    *,
    mono_s: Callable[[], float] = time.monotonic,
    wall_ns: Callable[[], int] = time.time_ns,
    by_speed: Callable[[SpeedDevice], bool] = lambda _device: True,
) -> SpeedHead:
    """`device` driven by speed with the rig's steps, latency, command timeout and rates."""
    servo = rig.servo
    return SpeedHead(
        device,
        rig.head,
        rig_speed_steps(rig),
        latency_s=servo.speed_latency_ms / 1000.0,
        command_timeout_s=servo.command_timeout_ms / 1000.0,
        poll_period_s=1.0 / servo.odometry_rate_hz,
        command_period_s=1.0 / servo.command_rate_hz,
        mono_s=mono_s,
        wall_ns=wall_ns,
        by_speed=by_speed,
    )
