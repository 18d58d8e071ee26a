"""The `servo` process: the serial link to the head (DESIGN §8; seed 000 §2, Fig. 1 — the servo
controller that takes angular demands and propagates odometry).

Inputs: `gaze/demand` (joint angles and rates).
Outputs: `servo/odometry` (joint angles, rates, the time the head read them), `servo/command`
(each fresh demand as written, limited, its stamps ending `("servo", t)` when its bytes were
written) and `servo/status` (link state, holding, errors, clamps, refusals, reconnects, the
head's response lag, how full the serial line was over the last second; on every change and
once a second).
Settings: [head] signs, zero offsets, joint, rate and acceleration limits, park angles; [servo]
protocol and its keys, port, baud, timeout_ms, command_timeout_ms, odometry_rate_hz,
command_rate_hz, reconnect_max_s.

The link itself — limits, set-points, hold, polls, odometry dating, reconnects, line load and
park on SIGTERM — is `gazed.servo.head_link.HeadLink`; this process carries its messages.
"""

from __future__ import annotations

from gazed.bus import Bus
from gazed.config import Rig
from gazed.messages import GazeDemand, Odometry, ServoStatus
from gazed.servo.head_link import HeadLink, LinkStatus
from gazed.servo.odometry import JointReading
from gazed.topics import GAZE_DEMAND, SERVO_COMMAND, SERVO_ODOMETRY, SERVO_STATUS
from services.runtime import HealthReport, Now, main

STAGE = "servo"


class ServoService:
    """Demands in, the head link stepped, odometry, commands and status published."""

    def __init__(self, rig: Rig, bus: Bus) -> None:
        self.rig = rig
        self.bus = bus
        self.demands = bus.subscribe(GAZE_DEMAND, capacity=64, immediate=True)
        self.odometry = bus.publisher(SERVO_ODOMETRY)
        self.status = bus.publisher(SERVO_STATUS)
        self.commands = bus.publisher(SERVO_COMMAND)
        self.link = HeadLink(
            rig, self.demands.take, self._publish_command, refused_upstream=self._malformed
        )

    def _malformed(self) -> int:
        return self.bus.stats.snapshot()[0].get(f"malformed:{GAZE_DEMAND.suffix}", 0)

    def step(self, now: Now) -> float:
        result = self.link.step(now)
        if result.odometry is not None:
            self._publish_odometry(result.odometry)
        if result.status is not None:
            self._publish_status(result.status)
        return result.wait_s

    def _publish_command(self, demand: GazeDemand, t_ns: int) -> None:
        self.commands.put(demand.stamped(STAGE, t_ns))

    def _publish_odometry(self, reading: JointReading) -> None:
        self.odometry.put(
            Odometry(
                t_capture_ns=reading.t_ns,
                stamps=((STAGE, reading.t_ns),),
                pan_rad=reading.pan_rad,
                tilt_rad=reading.tilt_rad,
                pan_rate_rad_s=reading.pan_rate_rad_s,
                tilt_rate_rad_s=reading.tilt_rate_rad_s,
                dead_reckoned=reading.dead_reckoned,
                zoom=reading.zoom,
            )
        )

    def _publish_status(self, status: LinkStatus) -> None:
        self.status.put(
            ServoStatus(
                t_capture_ns=status.t_ns,
                protocol=self.rig.servo.protocol,
                port=self.rig.servo.port,
                link=status.link,
                holding=status.holding,
                errors=status.errors,
                clamps=status.clamps,
                refused=status.refused,
                reconnects=status.reconnects,
                last_error=status.last_error,
                timeouts=status.timeouts,
                commands=status.commands,
                dead_reckoned=status.dead_reckoned,
                response_lag_s=status.response_lag_s,
                line_load=status.line_load,
            )
        )

    def health(self) -> HealthReport:
        return HealthReport(
            counters=self.link.counters(), stage_ms=self.link.stage_ms(), notes=self.link.notes()
        )

    def close(self) -> None:
        """Park the head, close the port, say so."""
        self._publish_status(self.link.close())


def build(rig: Rig, bus: Bus) -> ServoService:
    return ServoService(rig, bus)


if __name__ == "__main__":
    raise SystemExit(main("servo", build))
