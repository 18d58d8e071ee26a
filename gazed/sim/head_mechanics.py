"""The emulated head's mechanism: two axes in device angles, with the rig's rate and
acceleration limits ([head]), a command latency, an encoder of finite resolution and optional
backlash ([sim] `head_*` keys) — the platform of seed 000 §2 (Fig. 1) as the servo controller
sees it.

Commands are scheduled: an action decoded from the serial bytes at time t acts on the axes at
t + `head_latency_ms`. The motor side moves under `AxisMotion`; the encoder reads the motor; the
camera (output) side follows the motor through a dead band of `head_backlash_deg`
(o = clamp(o, m - b/2, m + b/2)), so the camera lags on every reversal while the encoder does
not. `pose_at(t)` gives the camera side at any instant of the last two seconds, which is what a
renderer needs. A third axis, `zoom`, moves the zoom position (0 widest, 1 longest) at up to
`[head] zoom_rate_max_s`; a head whose rig has no zoom lens simply never moves it.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

from gazed.config import HeadSection, SimSection
from gazed.geometry.kinematics import device_from_joint
from gazed.servo.axis_motion import STEP_S, AxisMotion

HISTORY_S = 2.0

Action = Callable[["HeadMechanics"], None]


@dataclass(frozen=True)
class AxisSample:
    """The camera side of both axes at `t_s` (device angles and rates)."""

    t_s: float
    pan_rad: float
    tilt_rad: float
    pan_rate_rad_s: float
    tilt_rate_rad_s: float
    zoom: float = 0.0


def device_bounds(head: HeadSection) -> tuple[tuple[float, float], tuple[float, float]]:
    """The joint limits of [head] as device-angle intervals (signs may swap their ends)."""
    lo = device_from_joint(head, head.pan_limits_rad[0], head.tilt_limits_rad[0])
    hi = device_from_joint(head, head.pan_limits_rad[1], head.tilt_limits_rad[1])
    return (min(lo[0], hi[0]), max(lo[0], hi[0])), (min(lo[1], hi[1]), max(lo[1], hi[1]))


class HeadMechanics:
    """Both axes of the emulated head, advanced in time by whoever drives the emulator."""

    def __init__(self, head: HeadSection, sim: SimSection, t0_s: float) -> None:
        (pan_lo, pan_hi), (tilt_lo, tilt_hi) = device_bounds(head)
        pan0, tilt0 = device_from_joint(head, *head.park_rad)
        pan_rate, tilt_rate = head.rate_max_rad_s
        pan_accel, tilt_accel = head.accel_max_rad_s2
        self.pan = AxisMotion(pan_rate, pan_accel, pan0, pan_lo, pan_hi)
        self.tilt = AxisMotion(tilt_rate, tilt_accel, tilt0, tilt_lo, tilt_hi)
        # A zoom motor reaches its speed within a tenth of a second.
        zoom_rate = head.zoom_rate_max_s
        self.zoom = AxisMotion(zoom_rate, 10.0 * zoom_rate, 0.0, 0.0, 1.0)
        self.latency_s = sim.head_latency_ms / 1000.0
        self.encoder_step_rad = math.radians(sim.head_encoder_resolution_deg)
        self.half_backlash_rad = math.radians(sim.head_backlash_deg) / 2.0
        self.t_s = t0_s
        self.commands = 0
        self._events: deque[tuple[float, Action]] = deque()
        self._output = [self.pan.position_rad, self.tilt.position_rad]
        self._rates = [0.0, 0.0]
        self._history: deque[AxisSample] = deque(maxlen=int(HISTORY_S / STEP_S))
        self._times: deque[float] = deque(maxlen=int(HISTORY_S / STEP_S))
        self._record()

    # --- commands --------------------------------------------------------------------------

    def schedule(self, t_s: float, action: Action) -> None:
        """Act on the axes `latency` after `t_s` (the moment the command was received)."""
        self.commands += 1
        self._events.append((t_s + self.latency_s, action))

    @property
    def settled(self) -> bool:
        """Nothing scheduled and both axes at rest where they were told to be."""
        return not self._events and self.pan.settled and self.tilt.settled and self.zoom.settled

    # --- time ------------------------------------------------------------------------------

    def advance(self, t_s: float) -> None:
        """Run the mechanism up to `t_s` (earlier times are ignored: time only moves forward)."""
        while self._events and self._events[0][0] <= t_s:
            t_event, action = self._events.popleft()
            self._integrate(t_event)
            action(self)
        self._integrate(t_s)

    def _integrate(self, t_s: float) -> None:
        if t_s <= self.t_s:
            return
        if (
            self.pan.settled
            and self.tilt.settled
            and self.zoom.settled
            and self._rates == [0.0, 0.0]
        ):
            self.t_s = t_s
            self._record()
            return
        while self.t_s < t_s:
            h = min(STEP_S, t_s - self.t_s)
            for i, axis in enumerate((self.pan, self.tilt)):
                axis.advance(h)
                before = self._output[i]
                motor = axis.position_rad
                after = min(
                    max(before, motor - self.half_backlash_rad), motor + self.half_backlash_rad
                )
                self._output[i] = after
                self._rates[i] = (after - before) / h
            self.zoom.advance(h)
            self.t_s += h
            self._record()

    def _record(self) -> None:
        sample = AxisSample(self.t_s, *self._output, *self._rates, self.zoom.position_rad)
        if self._times and self._times[-1] >= self.t_s:
            self._history[-1] = sample
            return
        self._history.append(sample)
        self._times.append(self.t_s)

    # --- readings --------------------------------------------------------------------------

    def encoder(self) -> tuple[float, float]:
        """What the encoders read now: the motor angles, quantised to the encoder's step."""
        return self._quantise(self.pan.position_rad), self._quantise(self.tilt.position_rad)

    def encoder_rates(self) -> tuple[float, float]:
        return self.pan.velocity_rad_s, self.tilt.velocity_rad_s

    def _quantise(self, angle_rad: float) -> float:
        step = self.encoder_step_rad
        return round(angle_rad / step) * step if step > 0 else angle_rad

    def pose_at(self, t_s: float) -> AxisSample:
        """The camera side at `t_s`: advanced to it if it is ahead, interpolated from the last
        two seconds if it is behind (the oldest sample if older still)."""
        if t_s >= self.t_s:
            self.advance(t_s)
            return self._history[-1]
        i = bisect.bisect_left(self._times, t_s)
        if i == 0:
            return self._history[0]
        a, b = self._history[i - 1], self._history[i]
        w = (t_s - a.t_s) / (b.t_s - a.t_s)
        return AxisSample(
            t_s,
            a.pan_rad + w * (b.pan_rad - a.pan_rad),
            a.tilt_rad + w * (b.tilt_rad - a.tilt_rad),
            a.pan_rate_rad_s + w * (b.pan_rate_rad_s - a.pan_rate_rad_s),
            a.tilt_rate_rad_s + w * (b.tilt_rate_rad_s - a.tilt_rate_rad_s),
            a.zoom + w * (b.zoom - a.zoom),
        )
