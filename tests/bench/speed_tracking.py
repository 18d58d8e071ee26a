"""Speed mode alone, on the emulated head's mechanism and a virtual clock (no noise from a busy
machine): how closely a head driven by speed steps follows pursuit set-points, for the speed
tables of the sim VISCA-over-IP rig (24 pan steps of 5 deg/s) and the sim ONVIF rig (32 steps
of 3.75 deg/s), against the same mechanism driven by position (each set-point an absolute
move); and how that changes when the head's latency differs from the rig's `speed_latency_ms`.

    python tests/bench/speed_tracking.py [--seconds 20]

Set-points at 50 Hz follow a sine of 25 deg (pan) and 6 deg (tilt, twice as fast) over 7 s,
polls at 50 Hz between them; a reading is in VISCA's 0.075 deg units. Each line gives the RMS
of head minus set-point, and of head minus the set-point a constant lag earlier (the lag that
fits best, which the estimator predicts over in the loop).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from speed_head_support import Mechanism, follow

from gazed.config import load_rig
from gazed.servo.speed_mode import speed_head
from gazed.servo.speed_steps import rig_speed_steps
from gazed.sim.head_mechanics import HeadMechanics

REPO = Path(__file__).resolve().parents[2]
RIGS = {"visca-ip": "sim-visca-ip.toml", "onvif": "sim-onvif.toml"}


def setpoint(t_s: float) -> tuple[float, float]:
    w = 2.0 * math.pi / 7.0
    return math.radians(25.0) * math.sin(w * t_s), math.radians(6.0) * math.sin(2.0 * w * t_s)


class Positions(Mechanism):
    """The mechanism driven by position: each set-point an absolute move at the fastest rate."""

    def set_position(self, pan_rad: float, tilt_rad: float) -> int:
        def move(m: HeadMechanics) -> None:
            m.pan.move_to(pan_rad)
            m.tilt.move_to(tilt_rad)

        self.mechanics.schedule(self.now[0], move)
        return self.now_ns


def run(name: str, mode: str, head_latency_ms: float, seconds: float) -> tuple[float, float, int]:
    rig = load_rig(REPO / "configs" / RIGS[name])
    rig = rig.model_copy(
        update={"sim": rig.sim.model_copy(update={"head_latency_ms": head_latency_ms})}
    )
    now = [0.0]
    mechanics = HeadMechanics(rig.head, rig.sim, 0.0)
    steps = rig_speed_steps(rig)
    rates_max = (steps[0].rates_rad_s[-1], steps[1].rates_rad_s[-1])
    device = (Mechanism if mode == "speed" else Positions)(mechanics, rates_max, now)
    head = speed_head(rig, device, mono_s=lambda: now[0], wall_ns=lambda: round(now[0] * 1e9))
    head.by_speed = mode == "speed"
    head.device.connect()
    samples = follow(head, mechanics, now, setpoint, seconds, 2.0)
    t = np.array([s[0] for s in samples])
    pan, tilt = np.array([s[1] for s in samples]).T

    def rms_deg(lag_s: float) -> float:
        sp = np.array([setpoint(x - lag_s) for x in t])
        return math.degrees(math.sqrt(np.mean((pan - sp[:, 0]) ** 2 + (tilt - sp[:, 1]) ** 2)))

    lags_ms = range(0, 150, 2)
    best_ms = min(lags_ms, key=lambda ms: rms_deg(ms / 1000.0))
    return rms_deg(0.0), rms_deg(best_ms / 1000.0), best_ms


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0)
    args = parser.parse_args()
    for name in RIGS:
        rig_latency_ms = load_rig(REPO / "configs" / RIGS[name]).servo.speed_latency_ms
        for mode, latencies in (
            ("position", [rig_latency_ms]),
            ("speed", [10.0, 20.0, 40.0, 60.0]),
        ):
            for latency_ms in latencies:
                raw, fitted, lag_ms = run(name, mode, latency_ms, args.seconds)
                print(
                    f"{name:<9} {mode:<8} head latency {latency_ms:4.0f} ms (rig "
                    f"{rig_latency_ms:.0f} ms): RMS {raw:.3f} deg, {fitted:.3f} deg "
                    f"{lag_ms} ms late"
                )


if __name__ == "__main__":
    main()
