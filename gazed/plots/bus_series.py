"""A run's series from the messages the loop published: a `gazed eval loop` run's record, or a
recording (`gazed plot run.mcap`).

Times count from the run's first capture. The gaze error needs the simulator's truth and the
camera's pose on the ground (`CameraPose`, from the rig); saccades are the gaze's entries into
`saccade`; the latency per hop comes from the stamps of the commands as written to the head.
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np
from pydantic import ValidationError

from gazed.eval.loop_metrics import gaze_errors_rad
from gazed.geometry.pose import CameraPose
from gazed.messages import (
    EstimatorState,
    GazeDemand,
    GazeState,
    Message,
    Prediction,
    SimTruth,
)
from gazed.plots.latency_hops import hop_latencies_ms
from gazed.plots.series import RunSeries, points
from gazed.record.mcap_reader import DamagedRecording, read_recording
from gazed.topics import (
    ESTIMATOR_PREDICTION,
    ESTIMATOR_STATE,
    GAZE_STATE,
    SERVO_COMMAND,
    SIM_TRUTH,
    split_key,
)

PLOTTED = (SIM_TRUTH, ESTIMATOR_STATE, ESTIMATOR_PREDICTION, GAZE_STATE, SERVO_COMMAND)


def bus_series(
    title: str,
    messages: dict[str, list[Message]],
    pose: CameraPose | None = None,
    fovea_half_deg: float | None = None,
) -> RunSeries:
    """The series of a run from its messages by key suffix (`sim/truth`, `estimator/state`,
    `estimator/prediction`, `gaze/state`, `servo/command`; any may be missing)."""
    truth = [m for m in messages.get(SIM_TRUTH.suffix, []) if isinstance(m, SimTruth)]
    states = [m for m in messages.get(ESTIMATOR_STATE.suffix, []) if isinstance(m, EstimatorState)]
    predictions = [
        m for m in messages.get(ESTIMATOR_PREDICTION.suffix, []) if isinstance(m, Prediction)
    ]
    gaze = [m for m in messages.get(GAZE_STATE.suffix, []) if isinstance(m, GazeState)]
    commands = [m for m in messages.get(SERVO_COMMAND.suffix, []) if isinstance(m, GazeDemand)]
    stamped = [*truth, *states, *predictions, *gaze, *commands]
    t0_ns = min((m.t_capture_ns for m in stamped), default=0)

    def seconds(items: list[Message]) -> np.ndarray:
        return (np.array([m.t_capture_ns for m in items], dtype=np.int64) - t0_ns) / 1e9

    run = RunSeries(title)
    run.truth_xy_m = points([t.target_xy_m for t in truth])
    run.estimate_xy_m = points([s.ground_xy_m for s in states if s.ground_xy_m is not None])
    on_ground = [p for p in predictions if p.ground_xy_m is not None]
    run.prediction_xy_m = points([p.ground_xy_m for p in on_ground])  # type: ignore[misc]
    if on_ground:
        run.prediction_horizon_s = float(np.median([p.horizon_s for p in on_ground]))
    if truth and pose is not None:
        run.error_t_s = seconds(list(truth))
        run.error_deg = np.degrees(gaze_errors_rad(truth, pose))
        run.fovea_half_deg = fovea_half_deg
    times = seconds(list(gaze))
    run.state_changes = [(float(t), g.state) for t, g in zip(times, gaze, strict=True)]
    run.saccade_t_s = [t for t, state in run.state_changes if state == "saccade"]
    with_models = [s for s in states if s.model_probabilities]
    if with_models:
        run.model_t_s = seconds(list(with_models))
        names = list(with_models[0].model_probabilities)
        run.model_probabilities = {
            n: np.array([s.model_probabilities.get(n, np.nan) for s in with_models]) for n in names
        }
    hops: dict[str, list[float]] = defaultdict(list)
    for command in commands:
        for stage, ms in hop_latencies_ms(command).items():
            hops[stage].append(ms)
    # in the loop's order: that of the command that passed the most stages
    order = [stage for stage, _ in max((c.stamps for c in commands), key=len, default=())]
    run.hops_ms = {stage: hops[stage] for stage in [*order, *hops] if stage in hops}
    return run


def recorded_messages(path: Path) -> tuple[dict[str, list[Message]], DamagedRecording | None]:
    """The plotted topics' messages of a recording by key suffix (a malformed one is skipped),
    and the damage that ended the reading early, if any: what came before it is kept."""
    wanted = {topic.suffix: topic for topic in PLOTTED}
    messages: dict[str, list[Message]] = defaultdict(list)
    try:
        for recorded in read_recording(path):
            parts = split_key(recorded.key)
            topic = wanted.get(parts[1]) if parts else None
            if topic is None:
                continue
            try:
                messages[topic.suffix].append(topic.model.model_validate_json(recorded.data))
            except ValidationError:
                continue
    except DamagedRecording as damage:
        return dict(messages), damage
    return dict(messages), None
