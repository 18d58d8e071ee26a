"""What a message costs to decode when it comes once every frame instead of back to back: the
same `decode_sample` (schema check, pydantic validation of a gaze demand) in zenoh's callback,
with the samples 0.5 ms apart and then 40 ms apart (the loop's rate: every process touches its
data once a frame, with the caches cold in between).

    python tests/bench/decode_cold.py [--samples 150]

One in-process zenoh session (no listening socket, no scouting) publishes to itself; prints the
median µs of `decode_sample` at each spacing.
"""

from __future__ import annotations

import argparse
import statistics
import time

import zenoh

from gazed.bus import Stats, decode_sample
from gazed.messages import GazeDemand
from gazed.topics import GAZE_DEMAND

KEY = "bench/decode"
WARM_UP = 10


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=150)
    args = parser.parse_args()
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("listen/endpoints", "[]")
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("scouting/gossip/enabled", "false")
    demand = GazeDemand(
        t_capture_ns=1,
        stamps=(("vision.arrival", 2), ("vision", 3), ("estimator", 4), ("gaze", 5)),
        kind="pursuit",
        pan_rad=0.1,
        tilt_rad=0.2,
    ).to_json()
    times_us: list[float] = []
    stats = Stats()

    def on_sample(sample: zenoh.Sample) -> None:
        started = time.perf_counter_ns()
        decode_sample(GAZE_DEMAND, sample, stats)
        times_us.append((time.perf_counter_ns() - started) / 1e3)

    with zenoh.open(config) as session:
        session.declare_subscriber(KEY, on_sample)
        encoding = zenoh.Encoding("application/json").with_schema(GazeDemand.schema_id())
        publisher = session.declare_publisher(KEY, encoding=encoding)
        for gap_s in (0.0005, 0.04):
            times_us.clear()
            for _ in range(args.samples + WARM_UP):
                publisher.put(demand)
                time.sleep(gap_s)
            median = statistics.median(times_us[WARM_UP:])
            print(f"samples {gap_s * 1e3:4.1f} ms apart: decode_sample median {median:6.1f} µs")


if __name__ == "__main__":
    main()
