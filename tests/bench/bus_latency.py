"""One-way latency on the bus between two processes, as a service sees it (sent -> decoded and
taken by the receiving loop), through the supervisor's router and over a direct peer link.

    python tests/bench/bus_latency.py [--count 2000] [--detection-rate-hz 500]

Three processes like a rig: this script holds the router-mode session; a sender and a receiver
connect to it, as clients (the sessions of tools: every message through the router) and then as
the rig's own `vision` and `estimator` (peers on this loopback bus: `[bus] peer_links`).
Detections are sent at 500 Hz and 640x480 RGB frames at 100 Hz (paced, so the figure is
latency, not queueing); the sender stamps `t_capture_ns` at send time. At the camera's rate
(`--detection-rate-hz 25`) every process sleeps between messages, as in the loop, and each
message costs more: the sessions' threads wake cold.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from gazed.bus import Bus
from gazed.config import load_rig
from gazed.messages import Detection, FrameHeader, HeadPose
from gazed.topics import SIM_FRAME, VISION_DETECTION
from gazed.wakeup import Wakeup

PORT = 17490


def rig_file(directory: Path) -> Path:
    path = directory / "benchbus.toml"
    path.write_text(f'[rig]\nname = "benchbus"\n[bus]\nlisten = ["tcp/127.0.0.1:{PORT}"]\n')
    return path


# the sessions' names: tools are the router's clients, the rig's processes peers of each other
NAMES = {"router": ("sender", "receiver"), "peer": ("vision", "estimator")}


def send(rig_path: Path, kind: str, count: int, links: str, detection_rate_hz: float) -> None:
    rig = load_rig(rig_path)
    with Bus(rig, NAMES[links][0]) as bus:
        publisher = bus.publisher(SIM_FRAME if kind == "frame" else VISION_DETECTION)
        while not publisher.matched():
            time.sleep(0.01)
        time.sleep(0.5)
        period_s = 0.01 if kind == "frame" else 1.0 / detection_rate_hz
        image = np.random.default_rng(0).integers(0, 256, (480, 640, 3), dtype=np.uint8)
        head = HeadPose(pan_rad=0.1, tilt_rad=-0.2, pan_rate_rad_s=0.01, tilt_rate_rad_s=0.02)
        next_s = time.monotonic()
        for seq in range(count + 50):  # the receiver stops after `count`
            if kind == "frame":
                header = FrameHeader(
                    t_capture_ns=time.time_ns(), seq=seq, width=640, height=480, encoding="rgb8"
                )
                publisher.put_frame(header, image)
            else:
                publisher.put(
                    Detection(
                        t_capture_ns=time.time_ns(),
                        seq=seq,
                        detector="flow",
                        found=True,
                        u_px=320.5,
                        v_px=240.25,
                        du_px_s=12.0,
                        dv_px_s=-3.0,
                        area_px=400.0,
                        confidence=0.9,
                        width_px=640,
                        height_px=480,
                        processing_ms=1.1,
                        head=head,
                        stamps=(("sim", time.time_ns()),),
                    )
                )
            next_s += period_s
            time.sleep(max(0.0, next_s - time.monotonic()))


def receive(rig_path: Path, kind: str, count: int, links: str) -> None:
    rig = load_rig(rig_path)
    latencies_ms: list[float] = []
    with Bus(rig, NAMES[links][1]) as bus, Wakeup() as wakeup:
        bus.on_arrival(wakeup.notify)
        subscription = bus.subscribe(SIM_FRAME if kind == "frame" else VISION_DETECTION)
        deadline = time.monotonic() + 120
        while len(latencies_ms) < count and time.monotonic() < deadline:
            wakeup.wait(1.0)
            for item in subscription.take():
                t_capture_ns = item.header.t_capture_ns if kind == "frame" else item.t_capture_ns
                latencies_ms.append((time.time_ns() - t_capture_ns) / 1e6)
    print(json.dumps(latencies_ms[:count]))


def measure(
    rig_path: Path, kind: str, count: int, links: str, detection_rate_hz: float
) -> dict[str, float]:
    me = [sys.executable, __file__, "--rig", str(rig_path), "--kind", kind, "--count", str(count)]
    me += ["--links", links, "--detection-rate-hz", str(detection_rate_hz)]
    receiver = subprocess.Popen([*me, "--role", "receiver"], stdout=subprocess.PIPE, text=True)
    sender = subprocess.Popen([*me, "--role", "sender"])
    out, _ = receiver.communicate(timeout=300)
    sender.wait(timeout=60)
    values = np.asarray(json.loads(out))
    p50, p99 = np.percentile(values, [50, 99])
    return {"n": int(values.size), "p50_ms": round(float(p50), 3), "p99_ms": round(float(p99), 3)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=2000)
    parser.add_argument("--role", choices=["sender", "receiver"])
    parser.add_argument("--kind", choices=["detection", "frame"])
    parser.add_argument("--rig", type=Path)
    parser.add_argument("--links", choices=list(NAMES), default="router")
    parser.add_argument("--detection-rate-hz", type=float, default=500.0)
    args = parser.parse_args()
    if args.role == "sender":
        send(args.rig, args.kind, args.count, args.links, args.detection_rate_hz)
        return 0
    if args.role == "receiver":
        receive(args.rig, args.kind, args.count, args.links)
        return 0
    with tempfile.TemporaryDirectory() as directory:
        rig_path = rig_file(Path(directory))
        with Bus(load_rig(rig_path), "router", router=True):
            results = {
                f"{kind} ({links})": measure(
                    rig_path, kind, args.count, links, args.detection_rate_hz
                )
                for links in NAMES
                for kind in ("detection", "frame")
            }
    detection_bytes = len(
        Detection(
            t_capture_ns=time.time_ns(),
            seq=1,
            detector="flow",
            found=True,
            width_px=640,
            height_px=480,
            head=HeadPose(pan_rad=0.1, tilt_rad=0.2),
        ).to_json()
    )
    for links in NAMES:
        print(
            f"{links}: detection message ({detection_bytes} B JSON, "
            f"{args.detection_rate_hz:g} Hz): {results[f'detection ({links})']}"
        )
        print(f"{links}: 640x480 RGB frame ({640 * 480 * 3} B): {results[f'frame ({links})']}")
    print(json.dumps(results))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
