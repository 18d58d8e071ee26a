"""The process loop: a sample of an `immediate` subscription runs the step at once in the bus's
receive thread (on the rig's peer links); otherwise (or while a step runs) it wakes the loop's
thread. Steps never overlap,
nothing is lost either way, a step that moves its deadline earlier gets it (not sooner), and
failures count the same on both paths."""

from __future__ import annotations

import itertools
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import pytest
from conftest import poll_until, write_rig

from gazed.bus import Bus, Publisher
from gazed.config import load_rig
from gazed.messages import Detection
from gazed.topics import VISION_DETECTION, health
from gazed.wakeup import Wakeup
from services import runtime
from services.runtime import (
    MAX_CONSECUTIVE_STEP_FAILURES,
    STEP_RETRY_S,
    HealthReport,
    Now,
    ServiceLoop,
    StopFlag,
)

IDLE_S = 60.0  # nothing to do until something arrives


def detection(seq: int) -> Detection:
    return Detection(
        t_capture_ns=seq + 1, seq=seq, detector="t", found=True, width_px=64, height_px=48
    )


class Recorder:
    """Takes detections and records every step: its thread, whether it ran as `immediate`, when,
    and what it took; whether two steps overlapped."""

    def __init__(self, bus: Bus, immediate: bool) -> None:
        self.detections = bus.subscribe(VISION_DETECTION, immediate=immediate)
        self.steps: list[tuple[int, bool, float, list[int]]] = []  # thread, immediate, mono, seqs
        self.next_wait_s = IDLE_S  # what an immediate step asks for
        self.fail = False  # every step from the first sample on raises
        self.inside = 0
        self.overlapped = False
        self.hold = threading.Event()  # set: the next step in the loop's thread blocks ...
        self.held = threading.Event()  # ... after its take, until `release`
        self.release = threading.Event()
        self.loop_thread: int | None = None
        self.closed = False

    def step(self, now: Now) -> float:
        self.inside += 1
        self.overlapped |= self.inside > 1
        try:
            seqs = [d.seq for d in self.detections.take()]
            self.steps.append((threading.get_ident(), now.immediate, now.mono_s, seqs))
            if threading.get_ident() == self.loop_thread and self.hold.is_set():
                self.hold.clear()
                self.held.set()
                assert self.release.wait(10.0)
            if self.fail and self.taken():
                raise RuntimeError("broken since the first sample")
            return self.next_wait_s if now.immediate else IDLE_S
        finally:
            self.inside -= 1

    def taken(self) -> list[tuple[int, int]]:
        """(seq, thread) of every detection taken."""
        return [(seq, thread) for thread, _, _, seqs in self.steps for seq in seqs]

    def health(self) -> HealthReport:
        return HealthReport()

    def close(self) -> None:
        self.closed = True


def running(
    bus: Bus, service: Recorder, wakeup: Wakeup
) -> tuple[ServiceLoop, threading.Thread, list[int]]:
    loop = ServiceLoop("vision", bus, service, StopFlag(), wakeup)
    result: list[int] = []

    def body() -> None:
        service.loop_thread = threading.get_ident()
        result.append(loop.run())

    thread = threading.Thread(target=body, daemon=True)
    thread.start()
    poll_until(lambda: service.steps, 5.0)  # the first step, at once
    return loop, thread, result


@dataclass
class Running:
    bus: Bus  # the service's session
    service: Recorder
    loop: ServiceLoop
    thread: threading.Thread  # the loop's
    result: list[int]  # the loop's exit code, once it returns
    publisher: Publisher[Detection]  # another session's, matched


@contextmanager
def running_on_a_rig(
    rig, process: str = "vision", immediate: bool = True, **settings: object
) -> Iterator[Running]:
    """A router, `process`'s session running a Recorder's loop, and a tool's publisher of
    detections; `settings` set on the Recorder before its loop starts."""
    with (
        Bus(rig, "router", router=True),
        Bus(rig, process) as bus,
        Bus(rig, "tool") as sender,
        Wakeup() as wakeup,
    ):
        service = Recorder(bus, immediate)
        for name, value in settings.items():
            setattr(service, name, value)
        loop, thread, result = running(bus, service, wakeup)
        publisher = sender.publisher(VISION_DETECTION)
        poll_until(publisher.matched, 5.0)
        yield Running(bus, service, loop, thread, result, publisher)


def stopped(bus: Bus, loop: ServiceLoop, thread: threading.Thread) -> None:
    loop.stop.set()
    bus.notify()
    thread.join(10.0)
    assert not thread.is_alive()


@pytest.fixture
def rig(tmp_path: Path):
    return load_rig(write_rig(tmp_path))


@pytest.mark.parametrize(
    ("process", "immediate", "stepped_at_once"),
    [("vision", True, True), ("vision", False, False), ("a-tool", True, False)],
)
def test_an_immediate_sample_is_stepped_in_the_receive_thread(
    rig, process: str, immediate: bool, stepped_at_once: bool
) -> None:
    """On the rig's peer links an immediate sample steps at once; a client of the router
    (here a tool's session) always wakes its loop instead."""
    with running_on_a_rig(rig, process, immediate) as r:
        assert r.bus.peer == (process == "vision")
        service = r.service
        for seq in range(5):
            r.publisher.put(detection(seq))
            poll_until(lambda seq=seq: len(service.taken()) > seq, 5.0)
        stopped(r.bus, r.loop, r.thread)
    assert [seq for seq, _ in service.taken()] == list(range(5))
    took = [
        (thread != service.loop_thread, flag) for thread, flag, _, seqs in service.steps if seqs
    ]
    assert took == [(stepped_at_once, stepped_at_once)] * 5  # in the receive thread, told so
    assert not service.overlapped
    assert service.closed


def test_a_sample_during_a_step_wakes_the_loop_and_is_not_lost(rig) -> None:
    with running_on_a_rig(rig) as r:
        service = r.service
        service.hold.set()
        r.bus.notify()  # the loop's thread steps, takes nothing and blocks
        assert service.held.wait(5.0)
        r.publisher.put(detection(0))  # arrives while that step runs: it cannot step now
        poll_until(lambda: r.bus.stats.snapshot()[1].get("vision/detection"), 5.0)
        service.release.set()
        poll_until(service.taken, 5.0)  # the loop steps again for it, long before IDLE_S
        stopped(r.bus, r.loop, r.thread)
    assert service.taken() == [(0, service.loop_thread)]
    assert not service.overlapped


def test_an_earlier_deadline_from_an_immediate_step_is_kept(rig) -> None:
    """The step for a sample asks to run again in 0.3 s (the loop slept for IDLE_S): the loop
    wakes for it then, not at once and not at IDLE_S."""
    with running_on_a_rig(rig, next_wait_s=0.3) as r:
        service = r.service
        r.publisher.put(detection(0))
        poll_until(lambda: len(service.steps) >= 3, 5.0)
        stopped(r.bus, r.loop, r.thread)
    (_, first_immediate, _, _), (_, immediate, sample_s, _), (_, later, due_s, _) = service.steps[
        :3
    ]
    assert (first_immediate, immediate, later) == (False, True, False)
    assert 0.3 <= due_s - sample_s < 0.6


def test_failing_immediate_steps_count_and_stop_the_loop(rig, monkeypatch) -> None:
    """The retries' pause is shortened here: the path is the same, only the waiting shorter."""
    retry_s = STEP_RETRY_S / 20
    monkeypatch.setattr(runtime, "STEP_RETRY_S", retry_s)
    with running_on_a_rig(rig, fail=True) as r:
        service, loop, result = r.service, r.loop, r.result
        r.publisher.put(detection(0))  # fails in the receive thread; the loop retries it
        r.thread.join(MAX_CONSECUTIVE_STEP_FAILURES * retry_s + 10.0)
    failing = service.steps[1:]
    assert failing[0][1] and not any(flag for _, flag, _, _ in failing[1:])
    assert len(failing) == loop.reporter.step_errors == MAX_CONSECUTIVE_STEP_FAILURES
    gaps_s = [b[2] - a[2] for a, b in itertools.pairwise(failing)]
    assert min(gaps_s) >= 0.9 * retry_s  # each retry after its pause, none doubled
    assert result == [1]  # the supervisor restarts a process that exits so
    assert service.closed


def test_steps_stop_at_close(rig) -> None:
    """After the loop closes the service, a sample no longer steps it."""
    with running_on_a_rig(rig) as r:
        service, result = r.service, r.result
        stopped(r.bus, r.loop, r.thread)
        steps = len(service.steps)
        r.publisher.put(detection(0))
        poll_until(lambda: r.bus.stats.snapshot()[1].get("vision/detection"), 5.0)
        time.sleep(0.1)  # a step would have run inline by now
    assert service.closed and result == [0]
    assert len(service.steps) == steps


def test_health_reports_the_keys_the_process_subscribes_and_publishes(rig) -> None:
    with Bus(rig, "router", router=True) as router:
        reports = router.subscribe(health("vision"))
        with Bus(rig, "vision") as bus, Wakeup() as wakeup:
            service = Recorder(bus, immediate=True)
            loop, thread, _ = running(bus, service, wakeup)
            report = poll_until(reports.latest, 5.0)
            stopped(bus, loop, thread)
    assert report.subscribes == ("vision/detection",)
    assert report.publishes == ("vision/health",)
