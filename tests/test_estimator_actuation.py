"""The estimator predicts to the instant the demand takes effect: its own stamp + the servo's
write gap (measured from `servo/command` stamps) + the head's response lag (from
`servo/status`), driven through `EstimatorService.step` on a stand-in bus."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from bench.estimator_hop import detections
from stand_in_bus import StandInBus

from gazed.config import load_rig
from gazed.messages import GazeDemand, Prediction, ServoStatus
from gazed.topics import ESTIMATOR_PREDICTION, SERVO_COMMAND, SERVO_STATUS, VISION_DETECTION
from services.estimator import STAGE, EstimatorService
from services.runtime import Now

SIM_RIG = Path(__file__).resolve().parents[1] / "configs" / "sim.toml"
WRITE_GAP_NS = 4_000_000


def servo_status(response_lag_s: float | None) -> ServoStatus:
    return ServoStatus(
        t_capture_ns=1,
        protocol="dynamixel",
        port="/dev/null",
        link="connected",
        response_lag_s=response_lag_s,
    )


def written_command() -> GazeDemand:
    """A demand the servo wrote 4 ms after the estimator stamped the prediction it came from."""
    t_ns = time.time_ns()
    return GazeDemand(
        t_capture_ns=t_ns,
        stamps=((STAGE, t_ns), ("servo", t_ns + WRITE_GAP_NS)),
        kind="pursuit",
        pan_rad=0.0,
        tilt_rad=0.0,
    )


def test_predictions_lead_by_the_write_gap_and_the_heads_response_lag() -> None:
    bus = StandInBus()
    service = EstimatorService(load_rig(SIM_RIG), bus)  # type: ignore[arg-type]
    stream = iter(detections(SIM_RIG, 40))

    def step(n: int) -> Prediction:
        for detection in (next(stream) for _ in range(n)):
            bus.inboxes[VISION_DETECTION.suffix].items.append(detection)
            service.step(Now(detection.t_capture_ns + 155_000_000, time.monotonic()))
        sent = bus.outboxes[ESTIMATOR_PREDICTION.suffix].sent
        assert sent, "no prediction published"
        return sent[-1]  # type: ignore[return-value]

    def lead_s(prediction: Prediction) -> float:
        return (prediction.t_effect_ns - dict(prediction.stamps)[STAGE]) / 1e9

    default_s = load_rig(SIM_RIG).estimator.actuation_latency_default_ms / 1000.0
    assert lead_s(step(10)) == pytest.approx(default_s, abs=1e-9)  # nothing measured yet

    bus.inboxes[SERVO_COMMAND.suffix].items.append(written_command())
    first = step(10)
    assert first.actuation_latency_s == pytest.approx(0.004, abs=1e-9)  # a head not measured yet
    assert lead_s(first) == pytest.approx(0.004, abs=1e-9)

    bus.inboxes[SERVO_STATUS.suffix].items.append(servo_status(0.05))
    lagged = step(10)
    assert lagged.actuation_latency_s == pytest.approx(0.054, abs=1e-9)
    assert lead_s(lagged) == pytest.approx(0.054, abs=1e-9)
    assert service.health().stage_ms["head_response_lag"] == 50.0

    bus.inboxes[SERVO_STATUS.suffix].items.append(servo_status(None))  # e.g. another head
    assert step(10).actuation_latency_s == pytest.approx(0.004, abs=1e-9)
