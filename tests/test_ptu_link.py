"""The servo's link to a PTU head, on the emulated line: replies that do not say what they
answer (PROTOCOLS §3) are still read as the answers they are while set-points and polls share
the line, and the head's room is asked before each set-point."""

from __future__ import annotations

import math

import pytest
from servo_link_support import demand
from test_servo_head_link import Link, odometry

RESOLUTION_RAD = math.radians(46.2857 / 3600)  # the emulated unit's, read at start-up


def test_every_poll_reads_both_axes_while_set_points_go_out() -> None:
    link = Link(protocol="flir-ptu")
    steps = link.run(1.0, keep_demanding=demand(20.0, -10.0))
    counters = link.link.counters()
    assert counters["commands"] > 10
    assert counters["errors"] == 0 and link.link.last_error is None
    assert counters.get("driver_stale_replies", 0) == 0
    polls = odometry(steps)
    assert len(polls) == counters["odometry"] >= 10
    last = polls[-1]
    assert last.pan_rad == pytest.approx(math.radians(20.0), abs=RESOLUTION_RAD)
    assert last.tilt_rad == pytest.approx(math.radians(-10.0), abs=RESOLUTION_RAD)
