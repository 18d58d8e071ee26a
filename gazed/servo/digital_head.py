"""The digital head (`[servo] protocol = "digital"`): no serial port, the head is a model in the
servo process — the emulated heads' mechanism (`gazed.sim.head_mechanics.HeadMechanics`) with
`[head]`'s rate and acceleration limits and `[servo] latency_ms` — whose pose the vision
process renders its view at (`gazed.vision.digital_view`).

It stands where the serial heads have a codec on a transport (`ServoDriver`), with the same
calls the head link makes (`connect`, `set_position`, `query_position`, `stop`), so the link's
limits, set-points, hold, odometry dating and park work on it unchanged. Its `codec` says what
the link asks of a protocol (it reports its position, exactly, its pan does not wrap) and its
`transport` is a line that takes no time. A position query is the model's exact pose at that
instant, so the odometry the servo publishes is the pose the view is rendered at.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

from gazed.config import DigitalServo, HeadSection, SimSection
from gazed.servo.driver import DevicePosition
from gazed.servo.transport import NotConnectedError
from gazed.sim.head_mechanics import HeadMechanics


@dataclass(frozen=True)
class DigitalTraits:
    """What the head link asks of a protocol, for the digital head."""

    protocol: str = "digital"
    can_report_position: bool = True
    pan_wraps: bool = False
    resolution_rad: tuple[float, float] = (0.0, 0.0)
    replies_identify_themselves: bool = False
    stop_needs_position: bool = False
    zooms: bool = True
    discarded_bytes: int = 0
    bad_frames: int = 0


@dataclass
class InstantLine:
    """A line with no bytes and no time on it (`LineLoadMeter` measures nothing): the digital
    head's, and an IP camera's, whose requests are not serial bytes."""

    url: str = "digital"
    baud: int = 0
    byte_time_s: float = 0.0
    line_s: float = 0.0

    def __init__(self, url: str = "digital") -> None:
        self.url = url
        self.counters: Counter[str] = Counter()  # the link's own counts: none

    def line_busy_s(self) -> float:
        return 0.0


class DigitalHead:
    """The head model behind the digital head's link; `mono_s` its clock, `wall_ns` the stamps'."""

    def __init__(
        self,
        head: HeadSection,
        servo: DigitalServo,
        *,
        mono_s: Callable[[], float] = time.monotonic,
        wall_ns: Callable[[], int] = time.time_ns,
    ) -> None:
        self.head = head
        self.codec = DigitalTraits()
        self.transport = InstantLine()
        self.counters: Counter[str] = Counter()
        self._mechanism = SimSection(
            head_latency_ms=servo.latency_ms, head_encoder_resolution_deg=0.0, head_backlash_deg=0.0
        )
        self._mono_s = mono_s
        self._wall_ns = wall_ns
        self.mechanics: HeadMechanics | None = None

    @property
    def is_connected(self) -> bool:
        return self.mechanics is not None

    def connect(self) -> None:
        """The model, at rest at the park angles (kept across a reconnect)."""
        if self.mechanics is None:
            self.mechanics = HeadMechanics(self.head, self._mechanism, self._mono_s())

    def disconnect(self) -> None:
        """Nothing to close: the model keeps its pose for the next `connect()`."""

    def _model(self) -> HeadMechanics:
        if self.mechanics is None:
            raise NotConnectedError("digital head: used before connect()")
        return self.mechanics

    def set_position(self, pan_rad: float, tilt_rad: float) -> int:
        """Both axes towards device angles, `latency_ms` from now; the time it was told (ns)."""
        model = self._model()
        now_s = self._mono_s()
        model.advance(now_s)
        model.schedule(now_s, lambda m: (m.pan.move_to(pan_rad), m.tilt.move_to(tilt_rad)))
        self.counters["setpoints"] += 1
        return self._wall_ns()

    def stop(self) -> int:
        model = self._model()
        now_s = self._mono_s()
        model.advance(now_s)
        model.schedule(now_s, lambda m: (m.pan.hold(), m.tilt.hold()))
        return self._wall_ns()

    def set_zoom(self, zoom: float) -> int:
        """The view's zoom towards position `zoom`, `latency_ms` from now (at `[head]
        zoom_rate_max_s`); the time it was told (ns)."""
        model = self._model()
        now_s = self._mono_s()
        model.advance(now_s)
        model.schedule(now_s, lambda m: m.zoom.move_to(zoom))
        return self._wall_ns()

    def query_zoom(self) -> float:
        """The model's exact zoom now."""
        return self._model().pose_at(self._mono_s()).zoom

    def query_position(self, between: Callable[[], None] | None = None) -> DevicePosition:
        """The model's exact pose now (device angles); `between` is unused (one reply)."""
        t_ns = self._wall_ns()
        pose = self._model().pose_at(self._mono_s())
        return DevicePosition(pose.pan_rad, pose.tilt_rad, t_ns, t_ns)
