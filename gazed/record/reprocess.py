"""`gazed replay run.mcap --rig RIG --reprocess`: a recording's frames and odometry fed to fresh
vision, estimator and gaze processes with the rig's settings, and their decisions compared with
the recorded ones.

The rig runs under `gazed run` on a private bus (its own name and port), with `sim` and `servo`
off and the camera reading frames from the bus; the recording's `sim/frame`, `servo/odometry`
and `servo/status` are replayed onto it retimed to now (`Replayer(retime=True)`), so the
processes take them as live. The head is as recorded: the new gaze's demands move nothing.
Compared: the detections frame by frame (by sequence number: found in both, the pixel
distance), the most likely motion model at each recorded capture, and the gaze's transitions.
"""

from __future__ import annotations

import tempfile
import threading
import time
import uuid
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import tomlkit
from tqdm import tqdm

from gazed.eval.loop import observed
from gazed.messages import Detection, EstimatorState, GazeState, Message
from gazed.record.mcap_reader import DamagedRecording, Recorded, read_recording
from gazed.record.replay_cli import Replayer
from gazed.topics import (
    ESTIMATOR_STATE,
    GAZE_STATE,
    SERVO_ODOMETRY,
    SERVO_STATUS,
    SIM_FRAME,
    SUPERVISOR_STATUS,
    VISION_DETECTION,
    split_key,
)

FED = (SIM_FRAME.suffix, SERVO_ODOMETRY.suffix, SERVO_STATUS.suffix)
DECISIONS = (VISION_DETECTION, ESTIMATOR_STATE, GAZE_STATE)
START_TIMEOUT_S = 90.0
SETTLE_S = 1.0  # after the last frame, for the last decisions to arrive


def reprocess_rig(rig_path: Path, directory: Path, port: int) -> Path:
    """A copy of the rig on a private bus, its sim and servo off, its camera the bus's frames."""
    document = tomlkit.parse(rig_path.read_text())
    base = rig_path.resolve().parent
    document["rig"]["name"] = f"reprocess{uuid.uuid4().hex[:8]}"
    bus = document.setdefault("bus", tomlkit.table())
    bus["listen"] = [f"tcp/127.0.0.1:{port}"]
    bus.pop("connect", None)
    bus["router"] = True
    for key in ("zenoh_config_path", "credentials_path"):
        if key in bus:
            bus[key] = str(base / str(bus[key]))
    document.pop("view", None)
    document.setdefault("camera", tomlkit.table())["source"] = "sim"
    services = document.setdefault("services", tomlkit.table())
    for name in ("sim", "servo"):
        services.setdefault(name, tomlkit.table())["enabled"] = False
    path = directory / "rig.toml"
    path.write_text(tomlkit.dumps(document))
    return path


def reprocess(
    recording: Path,
    rig_path: Path,
    rate: float,
    stop: threading.Event,
    port: int,
    bar: tqdm | None = None,
) -> dict[str, Any]:
    """Replay the recording's frames and odometry into fresh processes; compare their
    decisions with the recorded ones. A damaged file is reprocessed up to the damage. `bar`
    follows the recorded seconds replayed."""
    messages: list[Recorded] = []
    damage: DamagedRecording | None = None
    try:
        messages.extend(read_recording(recording))
    except DamagedRecording as exc:
        damage = exc
    recorded = _decisions(messages)
    with tempfile.TemporaryDirectory(prefix="gazed-reprocess-") as directory:
        private = reprocess_rig(rig_path, Path(directory), port)
        with observed(private, "reprocess", START_TIMEOUT_S) as (rig, bus, wakeup):
            subscriptions = {t.suffix: bus.subscribe(t, capacity=1_000_000) for t in DECISIONS}
            status = bus.subscribe(SUPERVISOR_STATUS)
            _wait_running(status, wakeup)
            replayer = Replayer(bus.session, rig.name, rate, stop, retime=True)
            for message in messages:
                parts = split_key(message.key)
                if parts is not None and parts[1] in FED and not replayer.publish(message):
                    break
                if bar is not None:
                    bar.update(replayer.position_s - bar.n)
            stop.wait(SETTLE_S)
            fresh = {suffix: s.take() for suffix, s in subscriptions.items()}
    report = compare(recorded, fresh, replayer.shift_ns)
    report["fed"] = dict(replayer.published)
    if damage is not None:
        report["damage"] = str(damage)
    return report


def _decisions(messages: list[Recorded]) -> dict[str, list[Message]]:
    found: dict[str, list[Message]] = {t.suffix: [] for t in DECISIONS}
    models = {t.suffix: t.model for t in DECISIONS}
    for message in messages:
        parts = split_key(message.key)
        if parts is not None and parts[1] in models:
            try:
                found[parts[1]].append(models[parts[1]].model_validate_json(message.data))
            except ValueError:
                continue
    return found


def compare(
    recorded: dict[str, list[Any]], fresh: dict[str, list[Any]], shift_ns: int
) -> dict[str, Any]:
    """The fresh decisions against the recorded ones (the fresh ones' times moved by
    `shift_ns`)."""
    old = {d.seq: d for d in recorded[VISION_DETECTION.suffix] if isinstance(d, Detection)}
    new = {d.seq: d for d in fresh[VISION_DETECTION.suffix] if isinstance(d, Detection)}
    both = sorted(old.keys() & new.keys())
    agree = [s for s in both if old[s].found == new[s].found]
    found = [s for s in both if old[s].found and new[s].found]
    distances = np.array(
        [np.hypot(old[s].u_px - new[s].u_px, old[s].v_px - new[s].v_px) for s in found]
    )
    old_models = _most_likely(recorded[ESTIMATOR_STATE.suffix], 0)
    new_models = _most_likely(fresh[ESTIMATOR_STATE.suffix], shift_ns)
    captures = old_models.keys() & new_models.keys()
    return {
        "detections": {
            "recorded": len(old),
            "reprocessed": len(new),
            "frames_in_both": len(both),
            "found_agrees": round(len(agree) / len(both), 4) if both else None,
            "found_in_both": len(found),
            "pixel_error_px": _summary(distances),
        },
        "most_likely_model": {
            "captures_in_both": len(captures),
            "agrees": round(
                sum(old_models[c] == new_models[c] for c in captures) / len(captures), 4
            )
            if captures
            else None,
        },
        "gaze_states": {
            "recorded": _transitions(recorded[GAZE_STATE.suffix]),
            "reprocessed": _transitions(fresh[GAZE_STATE.suffix]),
        },
    }


def _most_likely(states: list[Any], shift_ns: int) -> dict[int, str]:
    return {
        s.t_capture_ns - shift_ns: s.most_likely
        for s in states
        if isinstance(s, EstimatorState) and s.most_likely
    }


def _transitions(states: list[Any]) -> dict[str, int]:
    return dict(Counter(s.state for s in states if isinstance(s, GazeState)))


def _summary(values: np.ndarray) -> dict[str, float] | None:
    if not len(values):
        return None
    p50, p99 = np.percentile(values, [50, 99])
    return {
        "p50": round(float(p50), 3),
        "p99": round(float(p99), 3),
        "max": round(float(values.max()), 3),
        "within_1px": round(float(np.mean(values <= 1.0)), 4),
    }


def _wait_running(status: Any, wakeup: Any) -> None:
    deadline = time.monotonic() + START_TIMEOUT_S
    while time.monotonic() < deadline:
        wakeup.wait(0.5)
        latest = status.latest()
        if latest is not None and latest.state == "running":
            return
    raise RuntimeError("the reprocessing rig's processes did not come up")
