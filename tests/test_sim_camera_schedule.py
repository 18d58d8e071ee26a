"""The simulated camera's schedule on an injected clock: captures on the camera's clock, late
ones skipped, each scene rendered half a frame before its frame is due, frames published after
the visual latency, and the wake-up at the next of these."""

from __future__ import annotations

from gazed.sim.camera_schedule import CameraSchedule

PERIOD_S = 0.0625  # binary fractions: the instants add up exactly
LATENCY_S = 0.125


class Clock:
    def __init__(self, t_s: float) -> None:
        self.t_s = t_s

    def __call__(self) -> float:
        return self.t_s


def schedule(start_s: float = 8.0, latency_s: float = LATENCY_S) -> tuple[CameraSchedule, Clock]:
    clock = Clock(start_s)
    return CameraSchedule(PERIOD_S, latency_s, start_s, clock=clock), clock


def test_captures_fall_on_the_cameras_clock() -> None:
    s, _ = schedule()
    assert s.captures_due(7.99) == []
    assert s.captures_due(8.0) == [8.0]
    assert s.captures_due(8.07) == [8.0625]
    assert s.captures_due(8.12) == []
    assert s.captures_due(8.125) == [8.125]
    assert s.skipped == 0


def test_a_capture_more_than_a_frame_behind_is_skipped_never_queued() -> None:
    s, _ = schedule()
    s.captures_due(8.0)
    due = s.captures_due(8.0 + 3.5 * PERIOD_S)  # the first two are more than a frame behind
    assert due == [8.0 + 3 * PERIOD_S]
    assert s.skipped == 2
    assert s.captures_due(8.0 + 3.5 * PERIOD_S) == []  # nothing taken twice
    assert s.captures_due(8.0 + 5 * PERIOD_S) == [8.0 + 4 * PERIOD_S, 8.0 + 5 * PERIOD_S]
    assert s.skipped == 2  # a frame behind is caught up, not skipped


def test_scenes_render_half_a_frame_before_their_frames_are_due() -> None:
    s, clock = schedule()
    (t_s,) = s.captures_due(8.0)
    s.captured(t_s, "scene 0")
    render_at_s = t_s + LATENCY_S - 0.5 * PERIOD_S
    clock.t_s = render_at_s - 2**-10
    assert s.next_render() is None
    clock.t_s = render_at_s
    assert s.next_render() == "scene 0"
    assert s.next_render() is None
    s.rendered(t_s, "frame 0")
    assert s.next_publish() is None  # the visual latency has not passed
    clock.t_s = t_s + LATENCY_S
    assert s.next_publish() == "frame 0"
    assert s.next_publish() is None


def test_a_latency_under_half_a_frame_renders_at_capture() -> None:
    s, clock = schedule(latency_s=0.015625)
    (t_s,) = s.captures_due(8.0)
    s.captured(t_s, "scene")
    assert s.next_render() == "scene"  # due at the capture itself
    s.rendered(t_s, "frame")
    assert s.next_publish() is None
    clock.t_s = t_s + 0.015625
    assert s.next_publish() == "frame"


def test_the_wake_up_is_the_next_capture_render_or_publication() -> None:
    s, clock = schedule()
    s.captures_due(8.0)
    assert s.wait_s() == PERIOD_S  # only the next capture
    clock.t_s = 8.0 + 2 * PERIOD_S  # late: nothing negative
    assert s.wait_s() == 0.0
    for i, t_s in enumerate(s.captures_due(clock.t_s)):
        s.captured(t_s, f"scene {i}")
    # the first scene renders before the next capture: LATENCY_S - PERIOD_S / 2 after its own
    assert s.wait_s() == LATENCY_S - 1.5 * PERIOD_S
    clock.t_s = 8.0 + 2 * PERIOD_S + LATENCY_S - 0.5 * PERIOD_S
    scenes = []
    while (scene := s.next_render()) is not None:
        scenes.append(scene)
    assert scenes == ["scene 0", "scene 1"]  # in capture order

    short, clock = schedule(latency_s=0.015625)
    (t_s,) = short.captures_due(8.0)
    short.captured(t_s, "scene")
    short.rendered(t_s, short.next_render())
    assert short.wait_s() == 0.015625  # the publication, before the next capture
