"""The estimator's work without a bus: latencies from stamps, plausibility checks, predictions to
the effect time (and the baseline's at the capture), coasting when the detections stop, and
a detection the track has already passed."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from bench.estimator_hop import detections

from gazed.config import Rig, load_rig
from gazed.estimation.loop_latency import LoopLatency
from gazed.estimation.target_tracker import (
    FUTURE_TOLERANCE_NS,
    IDLE_S,
    TargetTracker,
    TrackUpdate,
)
from gazed.messages import Detection, GazeDemand, Mover

SIM_RIG = Path(__file__).resolve().parents[1] / "configs" / "sim.toml"
STAGE = "estimator"
ARRIVAL_NS = 150_000_000  # a detection reaches the estimator this long after its capture
STAMP_NS = 160_000_000  # ... and is stamped by it this long after


class Clock:
    """A wall clock the test sets."""

    def __init__(self) -> None:
        self.t_ns = 0

    def __call__(self) -> int:
        return self.t_ns


def tracker_for(rig: Rig) -> tuple[TargetTracker, Clock]:
    clock = Clock()
    return TargetTracker(rig, STAGE, clock_ns=clock), clock


def feed(tracker: TargetTracker, clock: Clock, detection: Detection) -> TrackUpdate | None:
    """`detection` arrives ARRIVAL_NS after its capture and is stamped STAMP_NS after it."""
    clock.t_ns = detection.t_capture_ns + STAMP_NS
    return tracker.update(detection, detection.t_capture_ns + ARRIVAL_NS)


def command(write_gap_ns: int, stage: str = STAGE) -> GazeDemand:
    return GazeDemand(
        t_capture_ns=1,
        stamps=((stage, 1_000), ("servo", 1_000 + write_gap_ns)),
        kind="pursuit",
        pan_rad=0.0,
        tilt_rad=0.0,
    )


def test_actuation_is_the_median_write_gap_plus_the_heads_response_lag() -> None:
    latency = LoopLatency(STAGE, actuation_default_s=0.03)
    assert latency.actuation_s == 0.03 and latency.visual_s == 0.0  # nothing measured yet
    for gap_ns in (4_000_000, 6_000_000, 5_000_000):
        latency.command_written(command(gap_ns))
    latency.command_written(command(90_000_000, stage="gaze"))  # no estimator stamp: ignored
    assert latency.actuation_s == pytest.approx(0.005, abs=1e-12)
    latency.head_responds(0.05)
    assert latency.actuation_s == pytest.approx(0.055, abs=1e-12)
    latency.head_responds(None)  # a head that cannot report its position
    assert latency.actuation_s == pytest.approx(0.005, abs=1e-12)
    for arrival_ns in (100_000_000, 300_000_000, 200_000_000):
        latency.detection_arrived(1_000, 1_000 + arrival_ns)
    assert latency.visual_s == pytest.approx(0.2)


def test_implausible_detections_are_dropped_and_counted() -> None:
    tracker, _ = tracker_for(load_rig(SIM_RIG))
    good = detections(SIM_RIG, 1)[0]
    now_ns = good.t_capture_ns + ARRIVAL_NS
    assert tracker.plausible(good, now_ns)
    future = good.model_copy(update={"t_capture_ns": now_ns + FUTURE_TOLERANCE_NS + 1})
    assert not tracker.plausible(future, now_ns)
    off = good.model_copy(update={"u_px": 3.0 * good.width_px})
    assert not tracker.plausible(off, now_ns)
    assert tracker.plausible(off.model_copy(update={"found": False}), now_ns)  # pixel unused
    assert tracker.counts["from_the_future"] == 1 and tracker.counts["off_the_image"] == 1


def test_predictions_lead_to_the_effect_time() -> None:
    tracker, clock = tracker_for(load_rig(SIM_RIG))
    default_s = tracker.latency.actuation_s
    for detection in detections(SIM_RIG, 20):
        update = feed(tracker, clock, detection)
        assert update is not None and update.prediction is not None
        prediction = update.prediction
        assert update.stamps[-1] == (STAGE, clock.t_ns)
        assert prediction.t_effect_ns == clock.t_ns + round(default_s * 1e9)
        assert prediction.horizon_s == pytest.approx((STAMP_NS + default_s * 1e9) / 1e9)
        assert prediction.visual_latency_s == pytest.approx(STAMP_NS / 1e9)
        assert not prediction.coasting
        state, _ = tracker.settle(update)
        assert state is not None and state.t_capture_ns == detection.t_capture_ns
    # the target moves: its predicted position is ahead of the state at the capture
    assert prediction.ground_xy_m != pytest.approx(state.ground_xy_m, abs=1e-3)
    assert tracker.counts["measured"] == 20 and tracker.latency.visual_s == ARRIVAL_NS / 1e9


def test_every_track_carries_its_filters_covariance_over_position_and_velocity() -> None:
    """The gaze takes a track back along its velocity with these (`walk_gate.point_fit`)."""
    tracker, clock = tracker_for(load_rig(SIM_RIG))
    for detection in detections(SIM_RIG, 12):
        update = feed(tracker, clock, detection)
        assert update is not None
        state, _ = tracker.settle(update)
    assert state is not None and len(state.tracks) == 1
    (track,) = state.tracks
    P = tracker.tracks.tracks[0].estimator.predict(detection.t_capture_ns / 1e9).covariance
    assert np.asarray(track.ground_cov_m2) == pytest.approx(P[:2, :2], rel=1e-12)
    assert np.asarray(track.ground_velocity_cov_m2_s2) == pytest.approx(P[2:, 2:], rel=1e-12)
    assert np.asarray(track.ground_position_velocity_cov_m2_s) == pytest.approx(P[:2, 2:])
    assert np.abs(P[:2, 2:]).max() > 0.0  # a filter's position and velocity are correlated


@pytest.mark.parametrize("bins", [64, 2, 1])  # the vision's own, and any a producer may send
def test_every_track_carries_its_appearance_model(bins: int) -> None:
    """The gaze tells a lost person's new track from someone else's by these (`look_gate`)."""
    tracker, clock = tracker_for(load_rig(SIM_RIG))
    rng = np.random.default_rng(5)
    clothes = rng.dirichlet(np.full(bins, 0.5))
    for detection in detections(SIM_RIG, 12):
        histogram = 0.9 * clothes + 0.1 * rng.dirichlet(np.full(bins, 0.5))
        mover = Mover(
            u_px=detection.u_px,
            v_px=detection.v_px,
            du_px_s=detection.du_px_s,
            dv_px_s=detection.dv_px_s,
            box_width_px=20.0,
            box_height_px=50.0,
            area_px=800.0,
            appearance=tuple(histogram.tolist()),
        )
        update = feed(tracker, clock, detection.model_copy(update={"movers": (mover,)}))
        assert update is not None
        state, _ = tracker.settle(update)
    assert state is not None and len(state.tracks) == 1
    (track,) = state.tracks
    model = tracker.tracks.tracks[0].appearance
    assert model is not None and model.taken == 11  # the first began it
    if bins == 1:
        assert track.look is None  # one bin tells nobody apart
        return
    assert track.look is not None
    assert np.asarray(track.look.template) == pytest.approx(model.template, rel=1e-12)
    assert (track.look.h2_mean, track.look.h2_shape) == (model.mean, model.shape)


def test_the_baseline_offers_the_estimate_at_the_capture() -> None:
    rig = load_rig(SIM_RIG)
    section = rig.estimator.model_copy(update={"predict_over_latency": False})
    tracker, clock = tracker_for(rig.model_copy(update={"estimator": section}))
    for detection in detections(SIM_RIG, 20):
        update = feed(tracker, clock, detection)
        assert update is not None and update.prediction is not None
        state, _ = tracker.settle(update)
    assert state is not None
    assert update.prediction.ground_xy_m == pytest.approx(state.ground_xy_m, abs=1e-12)
    assert update.prediction.t_effect_ns > detection.t_capture_ns + STAMP_NS  # still stamped ahead


def test_a_frame_without_the_target_coasts() -> None:
    tracker, clock = tracker_for(load_rig(SIM_RIG))
    stream = detections(SIM_RIG, 11)
    for detection in stream[:10]:
        feed(tracker, clock, detection)
    update = feed(tracker, clock, stream[10].model_copy(update={"found": False}))
    assert update is not None and update.coasting and update.prediction is not None
    assert update.prediction.coasting
    assert tracker.counts["coasted"] == 1 and tracker.counts["measured"] == 10


def test_a_detection_the_track_has_passed_is_rejected_after_its_prediction() -> None:
    tracker, clock = tracker_for(load_rig(SIM_RIG))
    stream = detections(SIM_RIG, 10)
    for detection in stream:
        update = feed(tracker, clock, detection)
        assert update is not None
        tracker.settle(update)
    late = stream[4]  # older than the track's state, arriving now
    update = tracker.update(late, stream[-1].t_capture_ns + ARRIVAL_NS)
    assert update is not None and update.prediction is not None
    assert tracker.settle(update) == (None, [])
    assert tracker.counts["rejected"] == 1


def test_silence_is_bridged_at_the_cameras_rate_up_to_coast_max() -> None:
    rig = load_rig(SIM_RIG)
    tracker, clock = tracker_for(rig)
    assert tracker.silent(0, 0.0) == (None, IDLE_S)  # no track yet
    stream = detections(SIM_RIG, 10)
    for detection in stream:
        feed(tracker, clock, detection)
    period_s = rig.camera.frame_period_s
    assert tracker.heard(100.0) == pytest.approx(2.0 * period_s)
    wall_ns = stream[-1].t_capture_ns + ARRIVAL_NS
    assert tracker.silent(wall_ns, 100.0 + period_s) == (None, period_s)  # not silent yet
    prediction, wait_s = tracker.silent(wall_ns, 100.0 + 2.5 * period_s)
    assert wait_s == period_s and prediction is not None and prediction.coasting
    assert prediction.stamps == ((STAGE, wall_ns),)
    assert prediction.t_effect_ns == wall_ns + round(tracker.latency.actuation_s * 1e9)
    coast_max_s = rig.estimator.coast_max_ms / 1000.0
    assert tracker.silent(wall_ns, 100.0 + coast_max_s + 1e-3) == (None, IDLE_S)
    assert tracker.counts["silent_predictions"] == 1


def test_silence_is_bridged_once_a_frame_period_however_often_it_is_asked() -> None:
    """The process steps on every arrival (servo commands, gaze states), not only on frames:
    a coasting prediction goes out once a frame period, not once a step."""
    rig = load_rig(SIM_RIG)
    tracker, clock = tracker_for(rig)
    stream = detections(SIM_RIG, 10)
    for detection in stream:
        feed(tracker, clock, detection)
    period_s = rig.camera.frame_period_s
    tracker.heard(100.0)
    wall_ns = stream[-1].t_capture_ns + ARRIVAL_NS
    silent_s = 100.0 + 2.5 * period_s
    first, _ = tracker.silent(wall_ns, silent_s)
    again, wait_s = tracker.silent(wall_ns, silent_s + 0.25 * period_s)  # woken by a command
    assert first is not None and again is None
    assert wait_s == pytest.approx(0.75 * period_s)
    later, _ = tracker.silent(wall_ns, silent_s + period_s)
    assert later is not None and tracker.counts["silent_predictions"] == 2


def test_maneuver_events_follow_the_state() -> None:
    tracker, clock = tracker_for(load_rig(SIM_RIG))
    events = []
    for detection in detections(SIM_RIG, 300):
        update = feed(tracker, clock, detection)
        assert update is not None
        _, new = tracker.settle(update)
        events += [(event, update) for event in new]
    assert events, "the simulated target turns: the most likely model changes"
    for event, update in events:
        assert event.t_capture_ns == update.t_capture_ns and event.stamps == update.stamps
        assert event.model != event.previous_model


def test_a_change_of_the_cameras_delay_retimes_the_tracks() -> None:
    """Frames stamped on arrival (vision's delay not known yet), then at their exposure once it
    is: the tracks built on the late stamps move back by the change, and the state is the one
    of a tracker told the delay from the start."""
    delay_ns = 200_000_000
    stream = detections(SIM_RIG, 20)
    late = [
        d.model_copy(update={"t_capture_ns": d.t_capture_ns + delay_ns, "delay_ms": 0.0})
        for d in stream[:10]
    ]
    told = [d.model_copy(update={"delay_ms": delay_ns / 1e6}) for d in stream]
    states = []
    for run in (late + told[10:], told):
        tracker, clock = tracker_for(load_rig(SIM_RIG))
        for detection in run:
            update = feed(tracker, clock, detection)
            assert update is not None
            state, _ = tracker.settle(update)
        assert state is not None and state.t_capture_ns == stream[-1].t_capture_ns
        states.append(state)
        assert tracker.counts["measured"] == 20
    hidden, known = states
    assert hidden.ground_velocity_m_s == pytest.approx(known.ground_velocity_m_s, abs=1e-6)
    assert hidden.ground_xy_m == pytest.approx(known.ground_xy_m, abs=1e-6)


def test_a_mover_without_a_velocity_is_measured_by_its_position_alone() -> None:
    """A mover seen for the first time, or whose region merged or split, reports (0, 0) and
    `velocity_known` false: that is no measurement of a person standing still."""
    (first, *_) = detections(SIM_RIG, 1)
    moving = Mover(u_px=first.u_px, v_px=first.v_px, du_px_s=40.0, dv_px_s=0.0)
    unknown = Mover(u_px=first.u_px + 200.0, v_px=first.v_px, velocity_known=False)
    tracker, _ = tracker_for(load_rig(SIM_RIG))
    sightings = tracker._sightings(first.model_copy(update={"movers": (moving, unknown)}))
    assert [s.measurement.velocity is not None for s in sightings] == [True, False]


@pytest.mark.parametrize("fraction", [(0.0, 0.0), (0.1, 0.05)])
def test_a_movers_point_is_as_uncertain_as_its_box_is_large(fraction: tuple) -> None:
    """Two movers at one point: the larger box's measurement is the less certain, by
    `mover_extent_noise` of its extent on each axis; a point mover (no box) keeps the detector's
    pixel noise alone, as the target of a detection without movers does."""
    rig = load_rig(SIM_RIG)
    rig = rig.model_copy(
        update={"estimator": rig.estimator.model_copy(update={"mover_extent_noise": fraction})}
    )
    (first, *_) = detections(SIM_RIG, 1)
    covariances = []
    for box in [(0.0, 0.0), (0.0, 0.0), (30.0, 80.0)]:
        mover = Mover(u_px=first.u_px, v_px=first.v_px, box_width_px=box[0], box_height_px=box[1])
        detection = first if not covariances else first.model_copy(update={"movers": (mover,)})
        tracker, clock = tracker_for(rig)
        feed(tracker, clock, detection)
        (track,) = tracker.tracks.tracks
        state = track.estimator.predict(detection.t_capture_ns / 1e9)
        assert state is not None
        covariances.append(state.covariance[:2, :2])
    own, point, box = covariances
    assert point == pytest.approx(own, rel=1e-9)
    assert (np.linalg.det(box) > 2.0 * np.linalg.det(point)) == (max(fraction) > 0.0)


def test_a_movers_sighting_carries_the_mixtures_tail() -> None:
    """With a tail weight, each mover's sighting holds the core's covariance and the tail's,
    the tail the wider along v (the range axis) by its share of the box; without, none."""
    rig = load_rig(SIM_RIG)
    (first, *_) = detections(SIM_RIG, 1)
    mover = Mover(u_px=first.u_px, v_px=first.v_px, box_width_px=30.0, box_height_px=80.0)
    detection = first.model_copy(update={"movers": (mover,)})
    for weight in (0.07, 0.0):
        section = rig.estimator.model_copy(
            update={
                "mover_extent_noise": (0.1, 0.05),
                "mover_extent_tail": (0.25, 0.5),
                "mover_extent_tail_weight": weight,
            }
        )
        tracker, _ = tracker_for(rig.model_copy(update={"estimator": section}))
        (sighting,) = tracker._sightings(detection)
        if weight == 0.0:
            assert sighting.tail_cov is None and sighting.tail_weight == 0.0
            continue
        assert sighting.tail_weight == weight and sighting.tail_cov is not None
        core = sighting.measurement.position_cov
        assert np.linalg.det(sighting.tail_cov) > 4.0 * np.linalg.det(core)
