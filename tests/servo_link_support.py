"""Helpers of the servo's tests: a rig, demands, the pan set-points written to a Pelco-D head."""

from __future__ import annotations

import itertools
import math
import time

from gazed.config import Rig, parse_rig
from gazed.messages import GazeDemand
from gazed.servo.pelco_d import EXTENDED, pan_deg_from_raw, split_frames

HEAD_SECTION = """[head]
pan_min_deg = -60
pan_max_deg = 60
tilt_min_deg = -40
tilt_max_deg = 20
pan_rate_max_deg_s = 300
tilt_rate_max_deg_s = 300
pan_accel_max_deg_s2 = 3000
tilt_accel_max_deg_s2 = 3000
park_pan_deg = 5
park_tilt_deg = -5
"""
"""A head of ±60° pan, -40..20° tilt, 300°/s, 3000°/s², parked at 5°, -5°."""


def link_rig(
    port: str = "unused",
    protocol: str = "pelco-d",
    baud: int = 9600,
    sections: str = "",
    **servo: object,
) -> Rig:
    """The `HEAD_SECTION` head on `protocol` at `baud`, answering 1 ms after a request and
    acting on it at once; `sections` adds rig sections (a [camera] with a zoom lens)."""
    keys = "\n".join(
        f"{k} = {str(v).lower() if isinstance(v, bool) else v}" for k, v in servo.items()
    )
    return parse_rig(
        f"""
[rig]
name = "link"
[servo]
protocol = "{protocol}"
port = "{port}"
baud = {baud}
timeout_ms = 50
command_timeout_ms = 300
reconnect_max_s = 2
{keys}
{HEAD_SECTION}{sections}
[sim]
head_latency_ms = 0
head_reply_delay_ms = 1
"""
    )


def demand(pan_deg: float, tilt_deg: float, kind: str = "position", pan_rate_deg_s: float = 0.0):
    return GazeDemand(
        t_capture_ns=time.time_ns(),
        kind=kind,
        pan_rad=math.radians(pan_deg),
        tilt_rad=math.radians(tilt_deg),
        pan_rate_rad_s=math.radians(pan_rate_deg_s),
    ).stamped("test")


class Demands:
    """A queue of demands the link pulls from, as from a bus subscription."""

    def __init__(self) -> None:
        self.waiting: list[GazeDemand] = []

    def put(self, *demands: GazeDemand) -> None:
        self.waiting += demands

    def take(self) -> list[GazeDemand]:
        taken, self.waiting = self.waiting, []
        return taken


def pan_setpoints_deg(written: list[bytes]) -> list[float]:
    """The pan set-points (0x4B frames) among the bytes written to a Pelco-D head."""
    frames = split_frames(bytearray(b"".join(written))).frames
    return [pan_deg_from_raw(f.word) for f, _ in frames if f.cmd2 == EXTENDED["set_pan"]]


def pan_steps_deg(written: list[bytes]) -> list[float]:
    """How far each pan set-point written moved from the one before."""
    return [b - a for a, b in itertools.pairwise(pan_setpoints_deg(written))]
