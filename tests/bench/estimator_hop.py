"""The estimator process's work per detection, without the bus: image -> ground with its
covariance, the filter update, the prediction over the latency and the messages it publishes
(`EstimatorService.step`, what the `estimator` hop of `gazed eval loop`'s `hops_p50` holds
besides the bus and the wake-up).

    python tests/bench/estimator_hop.py [--rig configs/sim.toml] [--detections 500] [--repeats 5]

Detections are made from the rig's simulated world: the `[sim]` trajectory's target, its
`[calibration] target_height_m` point seen through the true camera pose by a head that follows it
100 ms late, 25 per second. Every published message is encoded to JSON, as on the bus. Prints
the median and p90 µs per detection of each repeat (a fresh service each time).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from gazed.config import load_rig
from gazed.geometry.camera import CameraModel
from gazed.geometry.pose import CameraPose
from gazed.messages import Detection, HeadPose
from gazed.sim.world import trajectories
from services.estimator import EstimatorService
from services.runtime import Now

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "tests"))
from stand_in_bus import StandInBus  # noqa: E402  (tests/ is not a package)

FOLLOW_LAG_S = 0.1
RATE_STEP_S = 1e-3


def detections(rig_path: Path, n: int) -> list[Detection]:
    rig = load_rig(rig_path)
    trajectory, _ = trajectories(rig)
    pose, camera = CameraPose.from_rig(rig), CameraModel.from_section(rig.camera)
    height = rig.calibration.target_height_m
    period_s = rig.camera.frame_period_s
    t0_ns = time.time_ns() - round(n * period_s * 1e9) - 10**9

    def point(t_s: float) -> np.ndarray:
        return np.array([*trajectory.state(t_s).xy_m, height])

    out = []
    for k in range(n):
        t = k * period_s
        pan, tilt = (float(a) for a in pose.gaze_angles(point(t - FOLLOW_LAG_S)))
        ahead, behind = (pose.pixels(point(t + d), pan, tilt, camera) for d in (RATE_STEP_S, 0))
        u, v = behind
        du, dv = (ahead - behind) / RATE_STEP_S  # against the world: the head held still
        out.append(
            Detection(
                t_capture_ns=t0_ns + round(t * 1e9),
                stamps=(("vision", t0_ns + round(t * 1e9) + 150_000_000),),
                seq=k,
                detector="flow",
                found=True,
                u_px=float(u),
                v_px=float(v),
                du_px_s=float(du),
                dv_px_s=float(dv),
                area_px=900.0,
                confidence=0.8,
                compensated=True,
                width_px=camera.width_px,
                height_px=camera.height_px,
                head=HeadPose(pan_rad=pan, tilt_rad=tilt),
            )
        )
    return out


def step_us(rig_path: Path, stream: list[Detection]) -> tuple[list[float], EstimatorService]:
    service = EstimatorService(load_rig(rig_path), StandInBus(keep=False))  # type: ignore[arg-type]
    inbox = service.detections
    times = []
    for detection in stream:
        inbox.items.append(detection)
        now = Now(detection.t_capture_ns + 155_000_000, time.monotonic())
        started = time.perf_counter()
        service.step(now)
        times.append((time.perf_counter() - started) * 1e6)
    return times, service


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rig", type=Path, default=REPO / "configs" / "sim.toml")
    parser.add_argument("--detections", type=int, default=500)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    stream = detections(args.rig, args.detections)
    print("load average " + " ".join(f"{a:.2f}" for a in os.getloadavg()))
    print(f"estimator step per detection, {args.rig.name}, {args.detections} detections:")
    for _ in range(args.repeats):
        times, service = step_us(args.rig, stream[:])
        counts = service.tracker.counts
        print(
            f"  median {statistics.median(times):7.0f} µs, p90 {np.percentile(times, 90):7.0f} µs"
            f"  (measured {counts['measured']}, rejected {counts['rejected']},"
            f" filter {service.tracker.filter}, most likely {service.tracker.most_likely()})"
        )


if __name__ == "__main__":
    main()
