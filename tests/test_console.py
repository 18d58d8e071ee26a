"""`gazed run`'s view of the loop: a live line in a terminal, log lines elsewhere."""

from __future__ import annotations

import io
import logging

import pytest
from stand_in_bus import Inbox, StandInBus

from gazed.console import LiveStatus
from gazed.messages import ARRIVAL_STAGE, EstimatorState, GazeDemand, GazeState
from gazed.topics import ESTIMATOR_STATE, GAZE_STATE, SERVO_COMMAND


def feed(bus: StandInBus) -> None:
    """A state change, an estimate, three writes (to the inboxes that exist)."""
    bus.inboxes.setdefault(ESTIMATOR_STATE.suffix, Inbox())
    bus.inboxes.setdefault(SERVO_COMMAND.suffix, Inbox())
    bus.inboxes[GAZE_STATE.suffix].items.append(
        GazeState(
            t_capture_ns=1, state="pursuit", previous="saccade", reason="settled on the target"
        )
    )
    bus.inboxes[ESTIMATOR_STATE.suffix].items.append(
        EstimatorState(
            t_capture_ns=1,
            filter="imm",
            x=(0.0,),
            P=((1.0,),),
            most_likely="CS",
            ground_xy_m=(1.234, -0.5),
        )
    )
    for capture, processing_ms in (
        (10, 4.0),
        (10, 30.0),
        (11, 6.0),
    ):  # the second write of 10 is ignored
        bus.inboxes[SERVO_COMMAND.suffix].items.append(
            GazeDemand(
                t_capture_ns=capture,
                stamps=(
                    ("sim", 1_000_000),
                    (ARRIVAL_STAGE, 3_000_000),  # the frame's transport is not processing
                    ("servo", 3_000_000 + round(processing_ms * 1e6)),
                ),
                kind="pursuit",
                pan_rad=0.0,
                tilt_rad=0.0,
            )
        )


def test_live_line_in_a_terminal() -> None:
    bus, stream = StandInBus(), io.StringIO()
    status = LiveStatus(bus, stream, live=True)
    feed(bus)
    status.refresh(0.0, 5, 5)
    line = stream.getvalue().split("\r")[-1]
    assert line.startswith("gaze pursuit  target (+1.23, -0.50) m")
    assert "model CS" in line and "latency p50 5.0 ms" in line and "up 5/5" in line


def test_state_changes_are_logged_without_a_terminal(caplog: pytest.LogCaptureFixture) -> None:
    bus, stream = StandInBus(), io.StringIO()
    status = LiveStatus(bus, stream, live=False)
    feed(bus)
    with caplog.at_level(logging.INFO, logger="gazed.run"):
        status.refresh(0.0, 5, 5)
    assert stream.getvalue() == ""  # no status line in a journal
    assert status._estimates is None and status._commands is None  # nor the decoding it needs
    assert caplog.messages == ["gaze saccade -> pursuit: settled on the target"]
