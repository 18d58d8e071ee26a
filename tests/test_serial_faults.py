"""Serial faults under the real `servo` process: the device answers garbage, truncated replies,
NAKs or nothing for a while. The servo process reports it (servo/status, health, `gazed
status`), reconnects with backoff, never sends the head beyond its limits, and follows demands
again once the device recovers."""

from __future__ import annotations

import json
import math
import subprocess
from pathlib import Path

import numpy as np
import pytest
from conftest import PYTHON, child_env, free_tcp_port
from test_servo_process import Loop, start_servo, stop, write_servo_rig

from gazed.bus import Bus
from gazed.config import load_rig
from gazed.sim.head_emulator import HeadEmulator

pytestmark = pytest.mark.e2e  # every test here starts the real processes

VISCA_SYNTAX_ERROR = bytes.fromhex("906002ff")  # a NAK: camera 1, syntax error


class FaultyHead(HeadEmulator):
    """The emulated head, with a line that can go bad: every reply the device sends is
    replaced (garbage), cut (truncated), refused (nak) or lost (silent) while `fault` is set."""

    fault: str | None = None
    _rng = np.random.default_rng(7)

    def _write(self, data: bytes) -> None:
        if self.fault == "garbage":
            data = self._rng.integers(0, 256, len(data), dtype=np.uint8).tobytes()
        elif self.fault == "truncated":
            data = data[: len(data) // 2]
        elif self.fault == "nak":
            data = VISCA_SYNTAX_ERROR
        elif self.fault == "silent":
            return
        super()._write(data)


@pytest.mark.parametrize("fault", ["garbage", "truncated", "nak", "silent"])
def test_the_servo_rides_out_a_bad_line(tmp_path: Path, fault: str) -> None:
    rig_path = write_servo_rig(tmp_path, "visca", free_tcp_port())
    rig = load_rig(rig_path)
    with Bus(rig, "test", router=True) as bus, FaultyHead(rig) as head:
        loop = Loop(bus)
        servo = start_servo(rig_path)
        try:
            loop.until(lambda s: s.status is not None and s.status.link == "connected")
            loop.until(lambda s: s.odometry is not None
                       and abs(s.odometry.pan_rad - math.radians(10)) < 0.01,
                       keep_demanding=(10.0, 0.0))  # fmt: skip
            errors, timeouts = loop.status.errors, loop.status.timeouts

            head.fault = fault
            # the line is bad while demands keep coming, some beyond the limits
            loop.until(
                lambda s: s.status.link != "connected"
                or s.status.errors + s.status.timeouts > errors + timeouts + 2,
                timeout_s=15.0,
                keep_demanding=(80.0, -70.0),
            )  # fmt: skip
            report = subprocess.run(
                [PYTHON, "-m", "gazed.cli", "status", "--rig", str(rig_path),
                 "--json", "--seconds", "1.5"],
                capture_output=True, text=True, env=child_env(), timeout=60,
            )  # fmt: skip
            servo_entry = json.loads(report.stdout)["rigs"][rig.name]["processes"]["servo"]
            assert servo_entry["counters"], servo_entry  # `gazed status` shows the trouble

            head.fault = None
            loop.until(lambda s: s.status.link == "connected", timeout_s=20.0)
            loop.until(
                lambda s: s.odometry is not None
                and abs(s.odometry.pan_rad - math.radians(-20)) < 0.01,
                timeout_s=20.0,
                keep_demanding=(-20.0, 5.0),
            )  # fmt: skip
        finally:
            stop(servo)
        assert (
            head.mechanics.pan.clamps == 0 and head.mechanics.tilt.clamps == 0
        )  # never sent beyond
        pose = head.pose_at(head._clock())
        assert -60.0 <= math.degrees(pose.pan_rad) <= 60.0
