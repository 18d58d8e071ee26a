"""Wire schemas: round trips, stamps, refusal of non-finite numbers, malformed input counted."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import ValidationError

from gazed import messages as m
from gazed.bus import Stats, decode_sample
from gazed.topics import (
    TOPICS,
    VISION_DETECTION,
    alive_key,
    health,
    split_alive_key,
    split_key,
    topic_for,
)

HEAD = m.HeadPose(pan_rad=0.1, tilt_rad=-0.2, pan_rate_rad_s=0.3, tilt_rate_rad_s=-0.4)

SAMPLES: list[m.Message] = [
    m.FrameHeader(t_capture_ns=1, seq=3, width=640, height=480, encoding="bgr8"),
    m.Detection(
        t_capture_ns=2,
        seq=4,
        detector="flow",
        found=True,
        u_px=1.5,
        v_px=2.5,
        du_px_s=-3.0,
        dv_px_s=4.0,
        area_px=50.0,
        confidence=0.9,
        width_px=640,
        height_px=480,
        processing_ms=1.2,
        head=HEAD,
        movers=(
            m.Mover(u_px=1.5, v_px=2.5, box_width_px=8, box_height_px=20, appearance=(0.5, 0.5)),
            m.Mover(u_px=100.0, v_px=40.0, du_px_s=2.0, area_px=30.0, confidence=0.4),
        ),
    ),
    m.Candidates(
        t_capture_ns=3,
        seq=5,
        width_px=640,
        height_px=480,
        candidates=(m.Candidate(u_px=1, v_px=2, area_px=3, energy=4, score=5),),
        head=None,
    ),
    m.Odometry(t_capture_ns=4, pan_rad=0.5, tilt_rad=-0.1, pan_rate_rad_s=0.2),
    m.ServoStatus(
        t_capture_ns=5, protocol="pelco-d", port="/dev/ttyUSB0", link="connected", clamps=2
    ),
    m.GazeDemand(t_capture_ns=6, kind="pursuit", pan_rad=0.1, tilt_rad=0.2, pan_rate_rad_s=0.01),
    m.GazeState(t_capture_ns=7, state="pursuit", previous="saccade", reason="settled", target_id=3),
    m.GazeSelect(t_capture_ns=7, pixel_px=(320.0, 240.0), head=HEAD),
    m.EstimatorState(
        t_capture_ns=8,
        filter="imm",
        x=(1.0, 2.0),
        P=((1.0, 0.0), (0.0, 1.0)),
        model_probabilities={"CSD": 0.9, "CS": 0.05, "CD": 0.05},
        most_likely="CSD",
        target_id=1,
        tracks=(
            m.Track(
                id=1,
                confirmed=True,
                pan_rad=0.1,
                tilt_rad=-0.5,
                ground_xy_m=(3.0, 4.0),
                ground_velocity_m_s=(1.0, 0.0),
                ground_cov_m2=((0.01, 0.0), (0.0, 0.01)),
                age_s=2.5,
                hits=20,
                box_height_px=80.0,
                most_likely="CSD",
            ),
        ),
    ),
    m.Prediction(
        t_capture_ns=9,
        filter="imm",
        t_effect_ns=10,
        horizon_s=0.2,
        pan_rad=0.1,
        tilt_rad=0.2,
        pan_rate_rad_s=0.0,
        tilt_rate_rad_s=0.0,
        visual_latency_s=0.15,
        actuation_latency_s=0.05,
    ),
    m.ManeuverEvent(
        t_capture_ns=10,
        model="CS",
        previous_model="CSD",
        t_start_ns=9,
        previous_duration_s=2.0,
        mean_s_dot_m_s2=0.0,
        mean_theta_dot_rad_s=0.0,
    ),
    m.SimTruth(
        t_capture_ns=11,
        seq=1,
        target_xy_m=(1.0, 2.0),
        target_velocity_m_s=(0.5, 0.0),
        target_height_m=1.0,
        head=HEAD,
    ),
    m.Health(
        t_capture_ns=12,
        process="vision",
        pid=1,
        uptime_s=3.0,
        counters={"malformed": 1},
        subscribes=("servo/odometry", "sim/frame"),
        publishes=("vision/detection", "vision/health"),
    ),
    m.GazeCommand(
        t_capture_ns=14,
        command="trace",
        request_id="r1",
        pan_rad=0.1,
        tilt_rad=-0.1,
        max_samples=10,
    ),
    m.EdgeObservation(
        t_capture_ns=15,
        seq=3,
        found=True,
        u_px=1.0,
        v_px=2.0,
        ahead_px=(13.0, 2.0),
        behind_px=(-11.0, 2.0),
        head=HEAD,
    ),
    m.TraceResult(
        t_capture_ns=16, request_id="r1", samples_rad=((0.1, -0.1), (0.2, -0.1)), reason="a corner"
    ),
    m.SupervisorStatus(
        t_capture_ns=13,
        state="running",
        rig_path="/etc/gazed/a.toml",
        processes=(m.ProcessStatus(name="vision", state="running", pid=3, alive=True),),
    ),
]


@pytest.mark.parametrize("message", SAMPLES, ids=lambda msg: type(msg).__name__)
def test_round_trip(message: m.Message) -> None:
    stamped = message.stamped("vision", 100).stamped("estimator", 200)
    back = type(message).model_validate_json(stamped.to_json())
    assert back == stamped
    assert back.stamps == (("vision", 100), ("estimator", 200))


def test_every_topic_model_has_a_sample() -> None:
    assert {t.model for t in TOPICS} <= {type(s) for s in SAMPLES}


def test_schema_id_names_model_and_version() -> None:
    assert m.Detection.schema_id() == "gazed.Detection/5"  # movers, zoom, delay_ms, velocity_known
    assert m.Health.schema_id() == "gazed.Health/2"  # subscribes and publishes added


def test_stamped_uses_now_by_default() -> None:
    before = m.Odometry(t_capture_ns=1, pan_rad=0, tilt_rad=0)
    after = before.stamped("servo")
    assert before.stamps == ()
    assert after.stamps[0][0] == "servo" and after.stamps[0][1] > 1_600_000_000 * 10**9


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_numbers_are_refused(bad: float) -> None:
    with pytest.raises(ValidationError):
        m.GazeDemand(t_capture_ns=1, kind="position", pan_rad=bad, tilt_rad=0.0)
    text = b'{"t_capture_ns": 1, "kind": "position", "pan_rad": NaN, "tilt_rad": 0}'
    with pytest.raises(ValidationError):
        m.GazeDemand.model_validate_json(text)


def test_unknown_fields_are_refused() -> None:
    with pytest.raises(ValidationError):
        m.Odometry.model_validate_json(
            b'{"t_capture_ns": 1, "pan_rad": 0, "tilt_rad": 0, "zoom": 3}'
        )


def test_keys_split_and_resolve() -> None:
    assert split_key("gazed/lab/vision/detection") == ("lab", "vision/detection")
    assert split_key("other/lab/x") is None
    assert topic_for("vision/detection") is VISION_DETECTION
    assert topic_for("gaze/health") == health("gaze")
    assert topic_for("nothing/here") is None


@pytest.mark.parametrize(
    ("key", "parts"),
    [
        (alive_key("lab", "vision", 4242), ("lab", "vision", 4242)),
        ("gazed/lab/alive/vision", None),  # an older gazed's, without a pid
        ("gazed/lab/alive/vision/4242/1", None),
        ("gazed/lab/alive/vision/abc", None),
        ("gazed/lab/alive/vision/-1", None),
        ("gazed/lab/alive/vision/0", None),
        ("gazed/lab/alive/vision/007", None),  # another spelling of pid 7
        ("gazed/lab/alive/vision/\u00b2", None),  # a digit to str.isdigit, not to int()
        ("gazed/lab/alive/vision/\u0664\u0662", None),  # Arabic-Indic digits
        ("gazed/lab/vision/detection/1", None),
        ("other/lab/alive/vision/1", None),
    ],
)
def test_a_liveliness_key_names_a_process_and_its_pid(key: str, parts: object) -> None:
    assert split_alive_key(key) == parts


class FakeSample:
    """What `decode_sample` reads of a zenoh sample."""

    def __init__(self, payload: bytes, encoding: str, attachment: bytes | None = None) -> None:
        self.payload = FakeBytes(payload)
        self.encoding = encoding
        self.attachment = FakeBytes(attachment) if attachment is not None else None


class FakeBytes:
    def __init__(self, data: bytes) -> None:
        self.data = data

    def to_bytes(self) -> bytes:
        return self.data


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=300))
def test_any_bytes_decode_or_are_counted(payload: bytes) -> None:
    stats = Stats()
    for topic in TOPICS:
        result = decode_sample(
            topic,
            FakeSample(payload, f"application/json;{topic.model.schema_id()}", payload),
            stats,
        )
        assert result is None
    counters, _ = stats.snapshot()
    assert counters["malformed"] == len(TOPICS)


@settings(max_examples=200, deadline=None)
@given(
    st.dictionaries(
        st.sampled_from(
            ["t_capture_ns", "seq", "detector", "found", "u_px", "width_px", "height_px", "x"]
        ),
        st.one_of(st.integers(), st.floats(), st.text(max_size=5), st.booleans(), st.none()),
    )
)
def test_random_json_objects_decode_or_are_counted(fields: dict) -> None:
    import json

    stats = Stats()
    payload = json.dumps(fields).encode()
    result = decode_sample(
        VISION_DETECTION, FakeSample(payload, "application/json;gazed.Detection/5"), stats
    )
    counters, _ = stats.snapshot()
    assert (result is None) == (counters.get("malformed", 0) == 1)
    if result is not None:
        assert isinstance(result, m.Detection)


def test_schema_mismatch_is_malformed() -> None:
    stats = Stats()
    good = SAMPLES[1].to_json()
    assert (
        decode_sample(
            VISION_DETECTION, FakeSample(good, "application/json;gazed.Detection/5"), stats
        )
        is not None
    )
    assert (
        decode_sample(
            VISION_DETECTION, FakeSample(good, "application/json;gazed.Detection/1"), stats
        )
        is None
    )
    assert decode_sample(VISION_DETECTION, FakeSample(good, "application/json"), stats) is not None
    counters, _ = stats.snapshot()
    assert counters["malformed"] == 1
    assert stats.last_malformed is not None and "gazed.Detection/5" in stats.last_malformed


def test_a_selection_names_at_most_one_choice() -> None:
    assert m.GazeSelect(t_capture_ns=1).track_id is None  # hand the choice back to the rule
    assert m.GazeSelect(t_capture_ns=1, ground_xy_m=(1.0, 2.0)).ground_xy_m == (1.0, 2.0)
    with pytest.raises(ValidationError, match="one of"):
        m.GazeSelect(t_capture_ns=1, track_id=2, ground_xy_m=(1.0, 2.0))
    with pytest.raises(ValidationError, match="head pose"):
        m.GazeSelect(t_capture_ns=1, pixel_px=(3.0, 4.0))
