"""Look-and-move control (seed 004 §2: a PTZ camera that cannot image while moving): in place of
continuous pursuit, move, settle, look. It waits for a detection captured after the head
settled, then moves to where the target will be once the move and the settling are over;
detections captured while it moves are ignored."""

from __future__ import annotations

from collections.abc import Callable

from gazed.gaze.aim import Aim
from gazed.gaze.demand import make_demand
from gazed.gaze.move import Move
from gazed.messages import Detection, GazeDemand, Odometry


class LookAndMove:
    """`looking`: waiting for a fresh look (else moving); a look needs a frame captured since
    `look_since_ns`."""

    def __init__(self, move: Move) -> None:
        self.move = move
        self.looking = True
        self.look_since_ns = 0

    def restart(self) -> None:
        """Pursuit begins: look first."""
        self.looking = True

    def step(
        self,
        found: Detection | None,
        target: Callable[[Detection], Aim],
        odometry: Odometry | None,
        since_ns: int,
        wall_ns: int,
        mono_s: float,
    ) -> GazeDemand | None:
        """The demand of one tick: a move once a detection `found` since `since_ns` and since
        the head settled is in, to where `target(found)` says the target will be; the goal
        while moving; None (hold) while waiting for a look."""
        if self.looking:
            if found is None or found.t_capture_ns < max(self.look_since_ns, since_ns):
                return None
            goal = self.move.start(target(found), odometry, wall_ns)
            assert goal is not None  # a detection came with odometry
            self.looking = False
            return make_demand("position", goal.pan_rad, goal.tilt_rad, wall_ns, found)
        goal = self.move.goal
        assert goal is not None
        if self.move.over(odometry, mono_s):
            self.looking = True
            self.look_since_ns = wall_ns
        return make_demand("position", goal.pan_rad, goal.tilt_rad, wall_ns)
