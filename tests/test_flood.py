"""A flood of malformed messages on every key while the simulated rig tracks.

More than 10 000 malformed messages — bad JSON, the wrong schema, wrong types, NaN and infinity,
oversized payloads (1 MiB of noise, 1 MiB strings, 100 000-deep nesting), frames whose header lies
about their size — go to every key of the rig (each process's health key too) while `gazed run`
tracks the simulated target. Then:

- every process is alive, with the pid it had before, and no restart;
- each process counted, in its health, exactly the malformed messages sent on each key it reads
  (`malformed:<key>`), and every key some process reads was counted by one;
- the loop kept tracking: the target stayed in the fovea during the flood;
- nothing invalid reached the serial line: every command the servo wrote (`servo/command`) is
  finite and within the joint limits, the servo's `refused` counter is the number of malformed
  demands, and the emulated head (`sim/truth`) never left its limits.

Then well-formed but absurd demands (angles of 1e300 rad, rates of 1e300 rad/s, subnormal
numbers) on `gaze/demand`: the servo clamps them (counted), and the head still stays within its
limits. Every payload is checked offline first with the bus's own decoder, so the expected counts
are exact.
"""

from __future__ import annotations

import json
import math
import random
import time
import types
import typing
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import zenoh
from conftest import REPO, RunningSupervisor, poll_until
from pydantic import BaseModel

from gazed.bus import Bus, Stats, decode_sample
from gazed.config import SERVICE_NAMES
from gazed.eval.loop_metrics import gaze_errors_rad
from gazed.eval.private_rig import private_rig
from gazed.geometry.pose import CameraPose
from gazed.messages import FrameHeader, GazeDemand, GazeState, Health, Message, SimTruth
from gazed.topics import (
    GAZE_DEMAND,
    GAZE_STATE,
    PROCESSES,
    SERVO_COMMAND,
    SIM_TRUTH,
    TOPICS,
    Topic,
    health,
)

pytestmark = pytest.mark.e2e

READ_BY_PROCESSES = {t.suffix for p in PROCESSES for t in p.reads}
PER_READ_KEY = 1000  # with ~10 keys the processes read: > 10 000 messages where it matters
PER_OTHER_KEY = 100
FLOOD_S = 10.0  # spread over this long, so it is a flood and not one burst
MIB = 1 << 20
JSON = zenoh.Encoding("application/json")
Payload = tuple[bytes, zenoh.Encoding, bytes | None]  # payload, encoding, attachment


class OfflineSample:
    """What `decode_sample` reads of a zenoh sample, to check a payload before it is sent."""

    def __init__(self, payload: bytes, encoding: zenoh.Encoding, attachment: bytes | None) -> None:
        self.payload = zenoh.ZBytes(payload)
        self.encoding = encoding
        self.attachment = zenoh.ZBytes(attachment) if attachment is not None else None


def is_malformed(topic: Topic, payload: Payload) -> bool:
    return decode_sample(topic, OfflineSample(*payload), Stats()) is None  # type: ignore[arg-type]


def encoding(model: type[Message]) -> zenoh.Encoding:
    return JSON.with_schema(model.schema_id())


def example_value(annotation: Any) -> Any:
    """A plain valid value of a field's type (no constraints considered)."""
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if origin is typing.Annotated:
        return example_value(args[0])
    if origin is typing.Literal:
        return args[0]
    if origin in (typing.Union, types.UnionType):
        return example_value(next(a for a in args if a is not type(None)))
    if origin is tuple:
        return [example_value(a) for a in args if a is not Ellipsis] if Ellipsis not in args else []
    if origin in (list, dict):
        return [] if origin is list else {}
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return example_object(annotation)
    return {bool: False, int: 1, float: 0.5, str: "x"}.get(annotation)


def example_object(model: type[BaseModel]) -> dict[str, Any]:
    return {
        name: example_value(field.annotation)
        for name, field in model.model_fields.items()
        if field.is_required()
    }


def valid_example(model: type[Message]) -> dict[str, Any] | None:
    data = example_object(model)
    try:
        model.model_validate(data)
    except ValueError:
        return None
    return data


def float_fields(model: type[BaseModel]) -> list[str]:
    return [n for n, f in model.model_fields.items() if f.annotation in (float, "float")]


def json_candidates(topic: Topic, rng: random.Random) -> list[Payload]:
    """Malformed payloads of every kind for a JSON topic (some may turn out valid: filtered)."""
    model = topic.model
    good = valid_example(model)
    own = encoding(model)
    other = next(t.model for t in TOPICS if t.model is not model and not t.frames)
    other_example = valid_example(other) or {"t_capture_ns": 1}
    noise = [bytes(rng.getrandbits(8) for _ in range(rng.randrange(0, 200))) for _ in range(40)]
    candidates: list[Payload] = [(n, own, None) for n in noise]
    candidates += [
        (b"{not json", own, None),
        (b"", own, None),
        (b"null", own, None),
        (b"[1, 2, 3]", own, None),
        (b'"a string"', own, None),
        (b"\xff\xfe{\x00}", own, None),
        (json.dumps(other_example).encode(), own, None),  # another model, labelled as this one
        (json.dumps(other_example).encode(), JSON, None),  # another model, unlabelled
        (b"{}", own, None),
        (b'{"t_capture_ns": -1}', own, None),
        (b'{"t_capture_ns": "yesterday"}', own, None),
        (rng.randbytes(MIB), own, None),  # oversized noise
        (b"[" * 100_000 + b"]" * 100_000, own, None),  # nested deeper than any parser recursion
    ]
    if good is not None:
        text = json.dumps(good)
        candidates += [
            (text.encode(), encoding(other), None),  # right payload, wrong schema label
            (text[: len(text) // 2].encode(), own, None),  # truncated
            (json.dumps({**good, "extra": "x" * MIB}).encode(), own, None),  # oversized string
            (json.dumps({**good, "surprise": 1}).encode(), own, None),
        ]
        for name in good:  # wrong types, one field at a time
            for wrong in ([], {"a": 1}, "abc", None, [[1.5]], 10**40):
                candidates.append((json.dumps({**good, name: wrong}).encode(), own, None))
        for name in float_fields(model):  # non-finite numbers as JSON extensions write them
            for literal in ("NaN", "Infinity", "-Infinity", "1e999", '"nan"', '"inf"'):
                body = json.dumps({**good, name: 0.25}).replace("0.25", literal)
                candidates.append((body.encode(), own, None))
    return candidates


def frame_candidates(topic: Topic, rng: random.Random) -> list[Payload]:
    """Frames with lying, missing or garbage headers."""
    own = zenoh.Encoding("application/octet-stream").with_schema(topic.model.schema_id())
    header = FrameHeader(t_capture_ns=1, seq=1, width=64, height=48)
    big = FrameHeader(t_capture_ns=1, seq=1, width=16384, height=16384)
    candidates: list[Payload] = []
    for _ in range(40):
        size = rng.randrange(0, header.nbytes * 2)
        if size != header.nbytes:
            candidates.append((rng.randbytes(size), own, header.to_json()))  # lying header
    candidates += [
        (rng.randbytes(header.nbytes), own, None),  # no header
        (rng.randbytes(header.nbytes), own, b"{garbage"),
        (rng.randbytes(header.nbytes), own, rng.randbytes(64)),
        (rng.randbytes(16), own, big.to_json()),  # claims 768 MiB
        (rng.randbytes(MIB), own, header.to_json()),  # oversized, lying
        (
            rng.randbytes(header.nbytes),
            own,
            header.to_json().replace(b'"width":64', b'"width":-64'),
        ),
        (rng.randbytes(header.nbytes), own, header.to_json().replace(b'"seq":1', b'"seq":NaN')),
    ]
    return candidates


def flood_plan(rig_name: str, seed: int) -> list[tuple[str, Topic, Payload]]:
    """Malformed payloads for every key (each process's health key too), interleaved: more on
    the keys the processes read."""
    rng = random.Random(seed)
    topics = [*TOPICS, *(health(name) for name in SERVICE_NAMES)]
    per_topic = []
    for topic in topics:
        make = frame_candidates if topic.frames else json_candidates
        malformed = [p for p in make(topic, rng) if is_malformed(topic, p)]
        assert len(malformed) >= 20, topic.suffix
        count = PER_READ_KEY if topic.suffix in READ_BY_PROCESSES else PER_OTHER_KEY
        small = [p for p in malformed if len(p[0]) < 64 * 1024]  # the oversized ones go once
        chosen = malformed + [rng.choice(small) for _ in range(count - len(malformed))]
        rng.shuffle(chosen)
        per_topic.append([(topic.key(rig_name), topic, p) for p in chosen[:count]])
    longest = max(len(group) for group in per_topic)
    spread = [  # each key's messages spread evenly over the whole flood
        (k * longest / len(group), item) for group in per_topic for k, item in enumerate(group)
    ]
    return [item for _, item in sorted(spread, key=lambda pair: pair[0])]


def within(value: float, limits: tuple[float, float], tolerance: float = 1e-9) -> bool:
    return math.isfinite(value) and limits[0] - tolerance <= value <= limits[1] + tolerance


def malformed(report: Health) -> dict[str, int]:
    return {k: v for k, v in report.counters.items() if k.startswith("malformed")}


def test_malformed_flood_leaves_every_process_alive_counting_and_tracking(tmp_path: Path) -> None:
    rig_path = private_rig(REPO / "configs" / "sim.toml", tmp_path, "oval", None, None, 5, None)
    supervisor = RunningSupervisor(rig_path, tmp_path)
    rig = supervisor.rig
    observer = supervisor.bus
    plan = flood_plan(rig.name, seed=9)
    sent: dict[str, int] = {}
    for _, topic, _ in plan:
        sent[topic.suffix] = sent.get(topic.suffix, 0) + 1
    assert len(plan) >= 10_000
    truth = observer.subscribe(SIM_TRUTH, capacity=100_000)
    commands = observer.subscribe(SERVO_COMMAND, capacity=100_000)
    states = observer.subscribe(GAZE_STATE, capacity=1000)
    healths = {name: observer.subscribe(health(name), capacity=100) for name in SERVICE_NAMES}
    pan_limits, tilt_limits = rig.head.pan_limits_rad, rig.head.tilt_limits_rad
    record_truth: list[SimTruth] = []
    record_commands: list[GazeDemand] = []
    try:
        supervisor.wait_ready(60.0)
        pids = supervisor.pids()
        assert set(pids) == set(SERVICE_NAMES)

        def pursuing() -> bool:
            seen: list[GazeState] = states.take()
            return any(s.state == "pursuit" for s in seen)

        poll_until(pursuing, 30.0, 0.1)
        truth.take()
        with Bus(rig, "flood") as flood:
            started = time.monotonic()
            for k, (key, _, (payload, enc, attachment)) in enumerate(plan):
                flood.session.put(
                    key,
                    payload,
                    encoding=enc,
                    attachment=attachment,
                    congestion_control=zenoh.CongestionControl.BLOCK,
                )
                ahead_s = started + FLOOD_S * (k + 1) / len(plan) - time.monotonic()
                if ahead_s > 0:  # pacing the load, not synchronisation
                    time.sleep(ahead_s)
                record_truth.extend(truth.take())
                record_commands.extend(commands.take())
            flood_s = time.monotonic() - started
            after_ns = time.time_ns()

            fresh: dict[str, list[Health]] = {name: [] for name in healths}

            def counted() -> dict[str, Health] | None:
                """Each process's newest report once its malformed counters have stopped
                moving, the same in two reports after the flood (on a loaded machine the
                router still delivers the last samples after the flood has been sent)."""
                for name, subscription in healths.items():
                    fresh[name].extend(h for h in subscription.take() if h.t_capture_ns > after_ns)
                if any(len(r) < 2 or malformed(r[-1]) != malformed(r[-2]) for r in fresh.values()):
                    return None
                return {name: r[-1] for name, r in fresh.items()}

            reports = poll_until(counted, 15.0, 0.1)
        record_truth.extend(truth.take())
        record_commands.extend(commands.take())
        status = poll_until(supervisor.status, 5.0)

        # absurd but well-formed demands: clamped, never out of the limits
        with Bus(rig, "stranger") as stranger:
            demands = stranger.publisher(GAZE_DEMAND)
            poll_until(demands.matched, 5.0)
            for value in (1e300, -1e300, 5e-324, -0.0, 1e6, -1e6) * 10:
                demands.put(
                    GazeDemand(
                        t_capture_ns=time.time_ns(),
                        kind="pursuit",
                        pan_rad=value,
                        tilt_rad=-value,
                        pan_rate_rad_s=value,
                        tilt_rate_rad_s=value,
                    )
                )
            absurd_ns = time.time_ns()

            def servo_report() -> Health | None:
                fresh = [h for h in healths["servo"].take() if h.t_capture_ns > absurd_ns]
                return fresh[-1] if fresh else None

            servo_after = poll_until(servo_report, 10.0, 0.1)
        record_truth.extend(truth.take())
        record_commands.extend(commands.take())
        final_pids = supervisor.pids()
    finally:
        code = supervisor.stop()
    assert code == 0

    # alive, same pids, no restarts, nothing raised in a step
    assert final_pids == pids
    assert [(p.name, p.restarts) for p in status.processes if p.restarts] == []
    assert {name: r.counters.get("step_errors", 0) for name, r in reports.items()} == dict.fromkeys(
        SERVICE_NAMES, 0
    )

    # counted: exactly what was sent, by every reader of a key
    counted_by: dict[str, list[str]] = {}
    for name, report in reports.items():
        for suffix, n in sent.items():
            got = report.counters.get(f"malformed:{suffix}", 0)
            assert got in (0, n), f"{name} counted {got} of {n} malformed on {suffix}"
            if got:
                counted_by.setdefault(suffix, []).append(name)
        assert report.counters.get("malformed", 0) == sum(
            sent[s] for s in sent if name in counted_by.get(s, [])
        )
    assert {s for s in READ_BY_PROCESSES if s not in counted_by} == set()
    assert sum(sent[s] for s in counted_by) >= 10_000
    assert reports["servo"].counters["refused"] == sent[GAZE_DEMAND.suffix]

    # tracking went on during the flood (the target in the fovea)
    pose = CameraPose.from_rig(rig)
    during = sorted(record_truth, key=lambda t: t.t_capture_ns)
    errors = np.degrees(gaze_errors_rad(during, pose))
    in_fovea = float(np.mean(errors <= rig.gaze.fovea_half_angle_deg))
    print(f"flood {len(plan)} messages in {flood_s:.1f} s; fovea fraction {in_fovea:.3f}")
    assert len(during) > 5 * rig.camera.rate_hz
    assert in_fovea >= 0.7

    # nothing out of the limits on the line, absurd demands clamped
    assert record_commands
    for command in record_commands:
        assert within(command.pan_rad, pan_limits) and within(command.tilt_rad, tilt_limits)
        assert all(map(math.isfinite, (command.pan_rate_rad_s, command.tilt_rate_rad_s)))
    for t in record_truth:
        assert within(t.head.pan_rad, pan_limits, 1e-3) and within(
            t.head.tilt_rad, tilt_limits, 1e-3
        )
    assert servo_after.counters["demands"] > reports["servo"].counters["demands"]
    assert servo_after.counters["joint_clamps"] > reports["servo"].counters["joint_clamps"]
    assert servo_after.counters["refused"] == reports["servo"].counters["refused"]
