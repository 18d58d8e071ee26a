"""Raw VISCA over TCP (PTZOptics, `socket://host:5678`): a head link drives the emulated VISCA
camera through pyserial's socket transport, reads its odometry, follows demands, and when the
camera drops the connection reports the link down, retries with backoff and follows again."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from servo_link_support import Demands, demand, link_rig
from tcp_bridge_support import TcpBridge

from gazed.messages import GazeDemand
from gazed.servo.head_link import HeadLink, LinkStep
from gazed.servo.transport import SerialTransport
from gazed.sim.head_emulator import HeadEmulator
from services.runtime import Now


class LinkOverTcp:
    """A head link (real clocks) on `rig`, with what it read and reported kept."""

    def __init__(self, rig) -> None:
        self.demands = Demands()
        self.link = HeadLink(rig, self.demands.take, lambda *_: None)
        self.readings: list[tuple[float, float]] = []
        self.links: list[str] = []

    def run_until(self, done: Callable[[], bool], timeout_s: float, *demands: GazeDemand):
        deadline = time.monotonic() + timeout_s
        while not done():
            assert time.monotonic() < deadline, "condition not met"
            self.demands.put(*demands)
            step: LinkStep = self.link.step(Now.read())
            if step.odometry is not None:
                self.readings.append((step.odometry.pan_rad, step.odometry.tilt_rad))
            if step.status is not None:
                self.links.append(step.status.link)
            time.sleep(min(step.wait_s, 0.005))

    def at(self, pan_deg: float, tilt_deg: float) -> bool:
        if not self.readings:
            return False
        pan, tilt = self.readings[-1]
        return abs(math.degrees(pan) - pan_deg) < 0.2 and abs(math.degrees(tilt) - tilt_deg) < 0.2


def test_a_visca_camera_over_tcp_is_driven_and_reconnected_after_a_drop(tmp_path: Path) -> None:
    pty = tmp_path / "camera-pty"
    with TcpBridge(pty) as bridge:
        rig = link_rig(bridge.url, protocol="visca", baud=115200)
        servo = rig.servo.model_copy(update={"reconnect_max_s": 0.5, "timeout_ms": 250.0})
        # parked where the test leaves it: closing the link need not drive the head back
        head_section = rig.head.model_copy(update={"park_pan_deg": -15.0, "park_tilt_deg": 5.0})
        rig = rig.model_copy(update={"servo": servo, "head": head_section})
        with HeadEmulator(rig, link=pty) as camera:
            head = LinkOverTcp(rig)
            assert isinstance(head.link.driver.transport, SerialTransport)  # pyserial's socket
            head.run_until(lambda: head.at(20.0, 10.0), 5.0, demand(20.0, 10.0))
            pose = camera.device_pose_at(time.monotonic())
            assert math.degrees(pose.pan_rad) == pytest.approx(20.0, abs=0.2)
            assert head.link.link == "connected" and head.link.counts["errors"] == 0

            bridge.refusing = True
            bridge.drop()
            dropped_s = time.monotonic()
            head.run_until(lambda: len(bridge.attempts_s) >= 3, 5.0)  # the first, two retries
            assert head.link.link == "down" and "down" in head.links
            assert "socket://" in (head.link.last_error or "")  # the camera's refusal, said plainly
            first_retry_s, second_retry_s = bridge.attempts_s[1:3]
            assert first_retry_s - dropped_s >= 0.2  # the backoff's first 0.25 s
            assert second_retry_s - first_retry_s >= 0.4  # then doubled

            bridge.refusing = False
            head.run_until(lambda: head.at(-15.0, 5.0), 5.0, demand(-15.0, 5.0))
            status = head.link.close()
            assert head.link.counts["reconnects"] == 1 and status.reconnects == 1
            assert "connected" in head.links[head.links.index("down") :]
