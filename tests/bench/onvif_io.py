"""The ONVIF head against the emulated ONVIF camera on loopback: the command rate it sustains
(AbsoluteMove, ContinuousMove and GetStatus back to back, each a SOAP request with a fresh
WS-Security digest) and the time from a command to the first GetStatus that shows it moving.

    python tests/bench/onvif_io.py [--count 300] [--latency-ms 0]

`--latency-ms` is the emulated camera's own delay before it acts (`[sim] head_latency_ms`);
at 0 the figures are the protocol's and the host's alone.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from command_timing_support import command_to_reading_ms, rate_hz
from onvif_support import PASSWORD, onvif_rig

from gazed.servo.onvif_head import OnvifHead
from gazed.sim.head_onvif import OnvifEmulator


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=300)
    parser.add_argument("--latency-ms", type=float, default=0.0)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        rig = onvif_rig(Path(tmp))
        rig = rig.model_copy(
            update={"sim": rig.sim.model_copy(update={"head_latency_ms": args.latency_ms})}
        )
        with OnvifEmulator(rig) as _camera, OnvifHead(rig.servo, password=PASSWORD) as head:
            pan = [math.radians(10.0 * (i % 2)) for i in range(2)]
            figures = {
                "AbsoluteMove/s": rate_hz(lambda i: head.set_position(pan[i % 2], 0.0), args.count),
                "ContinuousMove/s": rate_hz(
                    lambda i: head.set_speed(0.1 * (-1) ** i, 0.0, 0.5), args.count
                ),
                "GetStatus/s": rate_hz(lambda i: head.query_position(), args.count),
            }
            head.stop()
            absolute = command_to_reading_ms(
                head, lambda i: head.set_position(math.radians(10.0 * (i % 2)), 0.0), 50
            )
            continuous = command_to_reading_ms(head, lambda i: head.set_speed(0.5, 0.0, 0.5), 50)
    for name, value in figures.items():
        print(f"{name:32s} {value:8.0f}")
    for name, (values, unseen) in (
        ("AbsoluteMove -> GetStatus", absolute),
        ("ContinuousMove -> GetStatus", continuous),
    ):
        print(f"{name + ' median ms':32s} {statistics.median(values):8.2f}")
        print(f"{name + ' not seen in 2 s':32s} {unseen:8d} of 50")


if __name__ == "__main__":
    main()
