"""The process loop: a sample of an `immediate` subscription runs the step at once in the bus's
receive thread; otherwise (or while a step runs) it wakes the loop's thread. Steps never overlap,
nothing is lost either way, and failures count the same on both paths."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest
from conftest import poll_until, write_rig

from gazed.bus import Bus
from gazed.config import load_rig
from gazed.messages import Detection
from gazed.topics import VISION_DETECTION
from services.runtime import MAX_CONSECUTIVE_STEP_FAILURES, HealthReport, Now, ServiceLoop, StopFlag


def detection(seq: int) -> Detection:
    return Detection(
        t_capture_ns=seq + 1, seq=seq, detector="t", found=True, width_px=64, height_px=48
    )


class Recorder:
    """Takes detections; records which thread took each, and whether two steps overlapped."""

    def __init__(self, bus: Bus, immediate: bool, fail: bool = False) -> None:
        self.detections = bus.subscribe(VISION_DETECTION, immediate=immediate)
        self.fail = fail  # every step from the first sample on raises
        self.taken: list[tuple[int, int]] = []  # (seq, thread id)
        self.inside = 0
        self.overlapped = False
        self.hold = threading.Event()  # set: the next step in the loop's thread blocks
        self.held = threading.Event()
        self.release = threading.Event()
        self.loop_thread: int | None = None
        self.closed = False

    def step(self, now: Now) -> float:
        self.inside += 1
        self.overlapped |= self.inside > 1
        try:
            if threading.get_ident() == self.loop_thread and self.hold.is_set():
                self.hold.clear()
                self.held.set()
                assert self.release.wait(10.0)
            for d in self.detections.take():
                self.taken.append((d.seq, threading.get_ident()))
            if self.fail and self.taken:
                raise RuntimeError("broken since the first sample")
            return 60.0  # nothing to do until something arrives
        finally:
            self.inside -= 1

    def health(self) -> HealthReport:
        return HealthReport()

    def close(self) -> None:
        self.closed = True


def running(bus: Bus, service: Recorder) -> tuple[ServiceLoop, threading.Thread, list[int]]:
    stop = StopFlag()
    loop = ServiceLoop("vision", bus, service, stop)
    result: list[int] = []

    def body() -> None:
        service.loop_thread = threading.get_ident()
        result.append(loop.run())

    thread = threading.Thread(target=body, daemon=True)
    thread.start()
    poll_until(lambda: service.loop_thread is not None, 5.0)
    return loop, thread, result


def stopped(bus: Bus, loop: ServiceLoop, thread: threading.Thread) -> None:
    loop.stop.set()
    bus.notify()
    thread.join(10.0)
    assert not thread.is_alive()


@pytest.mark.parametrize("immediate", [True, False])
def test_an_immediate_sample_is_stepped_in_the_receive_thread(
    tmp_path: Path, immediate: bool
) -> None:
    rig = load_rig(write_rig(tmp_path))
    with Bus(rig, "test", router=True) as bus, Bus(rig, "sender") as sender:
        service = Recorder(bus, immediate)
        loop, thread, _ = running(bus, service)
        publisher = sender.publisher(VISION_DETECTION)
        poll_until(publisher.matched, 5.0)
        for seq in range(5):
            publisher.put(detection(seq))
            poll_until(lambda seq=seq: len(service.taken) > seq, 5.0)
        stopped(bus, loop, thread)
    assert [seq for seq, _ in service.taken] == list(range(5))
    in_loop_thread = [tid == service.loop_thread for _, tid in service.taken]
    assert in_loop_thread == [not immediate] * 5
    assert not service.overlapped
    assert service.closed


def test_a_sample_during_a_step_wakes_the_loop_and_is_not_lost(tmp_path: Path) -> None:
    rig = load_rig(write_rig(tmp_path))
    with Bus(rig, "test", router=True) as bus, Bus(rig, "sender") as sender:
        service = Recorder(bus, immediate=True)
        loop, thread, _ = running(bus, service)
        publisher = sender.publisher(VISION_DETECTION)
        poll_until(publisher.matched, 5.0)
        service.hold.set()
        bus.notify()  # the loop's thread steps, and blocks inside the step
        assert service.held.wait(5.0)
        publisher.put(detection(0))  # arrives while that step runs
        poll_until(lambda: bus.stats.snapshot()[1].get("vision/detection"), 5.0)
        service.release.set()
        poll_until(lambda: service.taken, 5.0)
        stopped(bus, loop, thread)
    assert service.taken == [(0, service.loop_thread)]
    assert not service.overlapped


def test_failing_immediate_steps_count_and_stop_the_loop(tmp_path: Path) -> None:
    rig = load_rig(write_rig(tmp_path))
    with Bus(rig, "test", router=True) as bus, Bus(rig, "sender") as sender:
        service = Recorder(bus, immediate=True, fail=True)
        loop, thread, result = running(bus, service)
        publisher = sender.publisher(VISION_DETECTION)
        poll_until(publisher.matched, 5.0)
        publisher.put(detection(0))  # stepped in the receive thread; the loop retries after it
        thread.join(10.0)
    assert service.taken[0][1] != service.loop_thread
    assert result == [1]  # the supervisor restarts a process that exits so
    assert loop.reporter.step_errors == MAX_CONSECUTIVE_STEP_FAILURES
    assert service.closed
