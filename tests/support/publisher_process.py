"""Publishes COUNT stamped detections on a rig's bus as a client, once a subscriber matches.

python publisher_process.py --rig RIG --count N
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from gazed.bus import Bus
from gazed.config import load_rig
from gazed.messages import Detection
from gazed.topics import VISION_DETECTION


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--rig", type=Path, required=True)
    parser.add_argument("--count", type=int, required=True)
    args = parser.parse_args()
    rig = load_rig(args.rig)
    with Bus(rig, "publisher") as bus:
        publisher = bus.publisher(VISION_DETECTION)
        deadline = time.monotonic() + 10.0
        while not publisher.matched() and time.monotonic() < deadline:
            time.sleep(0.01)  # waiting for the subscriber's declaration to reach us
        for seq in range(args.count):
            t = time.time_ns()
            message = Detection(
                t_capture_ns=t,
                seq=seq,
                detector="test",
                found=True,
                u_px=seq,
                v_px=2.0 * seq,
                width_px=640,
                height_px=480,
            ).stamped("vision")
            publisher.put(message)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
