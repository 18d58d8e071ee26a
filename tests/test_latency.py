"""LatencyWindow: the median of the latest samples, the default before the first, bad samples
ignored; stage_gap_s reads two stamps of one message."""

from __future__ import annotations

import math

from gazed.latency import LatencyWindow, stage_gap_s
from gazed.messages import Detection


def test_window_median_follows_its_latest_samples() -> None:
    window = LatencyWindow(default_s=0.02, size=3)
    assert window.median_s == 0.02 and window.count == 0
    for sample in (0.1, 0.3, 0.2):
        window.add(sample)
    assert window.median_s == 0.2
    window.add(0.5)  # 0.1 leaves the window
    assert window.count == 3 and window.median_s == 0.3
    for bad in (math.nan, math.inf, -0.1):
        window.add(bad)
    assert window.count == 3 and window.median_s == 0.3


def test_stage_gap_between_two_stamps() -> None:
    detection = Detection(
        t_capture_ns=1_000,
        stamps=(("sim", 2_000_000), ("vision", 5_000_000)),
        seq=1,
        detector="flow",
        found=False,
        width_px=640,
        height_px=480,
    )
    assert stage_gap_s(detection, "sim", "vision") == 0.003
    assert stage_gap_s(detection, "sim", "servo") is None


def test_window_max_is_the_largest_latest_sample() -> None:
    window = LatencyWindow(default_s=0.02, size=2)
    assert window.max_s == 0.02
    for sample in (0.3, 0.1):
        window.add(sample)
    assert window.max_s == 0.3
    window.add(0.2)  # 0.3 leaves the window
    assert window.max_s == 0.2
