"""`gazed latency`: per-stage and end-to-end latency of every key, from the messages' stamps,
and the camera's delay from exposure to arrival that vision takes off each frame's capture stamp
(from its health), so that the first stage's latency starts at the exposure."""

from __future__ import annotations

import argparse
import json
import sys
import threading
import time
from collections import defaultdict
from typing import Any

import numpy as np

from gazed.bustools.listen import Seen, common_arguments, listen, target_of
from gazed.messages import Health, Message
from gazed.topics import PREFIX


def latency_arguments(parser: argparse.ArgumentParser) -> None:
    common_arguments(parser)
    parser.add_argument("--seconds", type=float, default=5.0, help="listen this long (default 5)")


def latency_command(args: argparse.Namespace) -> int:
    target = target_of(args)
    stamped: list[tuple[str, Message]] = []
    vision: list[Health] = []
    lock = threading.Lock()

    def on_seen(seen: Seen) -> None:
        message = seen.message
        with lock:
            if isinstance(message, Health) and message.process == "vision":
                vision.append(message)
            elif message is not None and message.stamps:
                stamped.append((seen.key, message))

    session = listen(target, f"{PREFIX}/{target.rig}/**", on_seen)
    try:
        time.sleep(args.seconds)  # listening window
    finally:
        session.close()
    if not stamped:
        print(
            f"gazed latency: no stamped messages for rig '{target.rig}' in {args.seconds:g} s",
            file=sys.stderr,
        )
        return 1
    report = latency_report(stamped, vision[-1] if vision else None)
    print(json.dumps(report, indent=2) if args.json else latency_text(report))
    return 0


def latency_report(
    stamped: list[tuple[str, Message]], vision: Health | None = None
) -> dict[str, Any]:
    """Per key: each stage's latency (its stamp minus the previous one, the first minus
    t_capture) and end to end (last stamp minus t_capture), p50/p95/p99 in ms; with vision's
    latest health, the camera delay it applies."""
    stages: dict[str, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    end_to_end: dict[str, list[float]] = defaultdict(list)
    for key, message in stamped:
        suffix = key.split("/", 2)[2] if key.count("/") >= 2 else key
        previous = message.t_capture_ns
        for stage, t_ns in message.stamps:
            stages[suffix][stage].append((t_ns - previous) / 1e6)
            previous = t_ns
        end_to_end[suffix].append((message.stamps[-1][1] - message.t_capture_ns) / 1e6)
    report: dict[str, Any] = {
        "keys": {
            suffix: {
                "n": len(end_to_end[suffix]),
                "stages_ms": {stage: _percentiles(values) for stage, values in per_stage.items()},
                "end_to_end_ms": _percentiles(end_to_end[suffix]),
            }
            for suffix, per_stage in sorted(stages.items())
        }
    }
    if vision is not None and "camera_delay" in vision.stage_ms:
        report["camera_delay"] = {
            "ms": vision.stage_ms["camera_delay"],
            "note": vision.notes.get("camera_delay", ""),
        }
    return report


def _percentiles(values: list[float]) -> dict[str, float]:
    p50, p95, p99 = np.percentile(np.asarray(values), [50, 95, 99])
    return {"p50": round(float(p50), 3), "p95": round(float(p95), 3), "p99": round(float(p99), 3)}


def latency_text(report: dict[str, Any]) -> str:
    lines = [f"{'key / stage':<36} {'p50':>9} {'p95':>9} {'p99':>9}  (ms)"]
    for suffix, entry in report["keys"].items():
        e = entry["end_to_end_ms"]
        lines.append(
            f"{suffix + ' (end to end, n=' + str(entry['n']) + ')':<36} "
            f"{e['p50']:9.2f} {e['p95']:9.2f} {e['p99']:9.2f}"
        )
        for stage, s in entry["stages_ms"].items():
            lines.append(f"  {stage:<34} {s['p50']:9.2f} {s['p95']:9.2f} {s['p99']:9.2f}")
    if "camera_delay" in report:
        lines.append(
            f"camera delay (exposure -> arrival, taken off capture stamps by vision): "
            f"{report['camera_delay']['note']}"
        )
    return "\n".join(lines)
