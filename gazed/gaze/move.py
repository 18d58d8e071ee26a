"""A move of the head: its goal, and when it is over (the head at rest at the goal for the
settling time; seed 000 §2: detections taken while the head turns are blurred and off their
track)."""

from __future__ import annotations

import math

from gazed.gaze.aim import Aim, MoveLimits, angle_between, arrival_aim
from gazed.geometry.kinematics import HeadKinematics
from gazed.messages import HeadPose, Odometry

STILL_RATE_RAD_S = math.radians(2.0)  # below this the head counts as at rest


def at_rest(pose: HeadPose | Odometry) -> bool:
    """Both joints turning slower than STILL_RATE_RAD_S."""
    return max(abs(pose.pan_rate_rad_s), abs(pose.tilt_rate_rad_s)) < STILL_RATE_RAD_S


def at_goal(
    odometry: Odometry | None,
    goal_rad: tuple[float, float],
    tolerance_rad: float,
    kinematics: HeadKinematics,
) -> bool:
    """The head at rest, looking within `tolerance_rad` of the goal's direction."""
    if odometry is None:
        return False
    return (
        at_rest(odometry)
        and angle_between(odometry.pan_rad, odometry.tilt_rad, *goal_rad, kinematics)
        <= tolerance_rad
    )


class Settling:
    """Since when the head has been at rest at its goal; a move is over once it has been for
    `settle_s`. `restart()` when a new move begins."""

    def __init__(self, kinematics: HeadKinematics, tolerance_rad: float, settle_s: float) -> None:
        self.kinematics = kinematics
        self.tolerance_rad = tolerance_rad
        self.settle_s = settle_s
        self.since_s: float | None = None

    def restart(self) -> None:
        self.since_s = None

    def settled(
        self, odometry: Odometry | None, goal_rad: tuple[float, float], mono_s: float
    ) -> bool:
        """At the goal and at rest since `settle_s` ago or longer."""
        if not at_goal(odometry, goal_rad, self.tolerance_rad, self.kinematics):
            self.since_s = None
            return False
        if self.since_s is None:
            self.since_s = mono_s
        return mono_s - self.since_s >= self.settle_s


class Move:
    """A ballistic move (saccade, look-and-move): to where its target will be when the move,
    at the head's limits, and the settling are over (`arrival_aim`)."""

    def __init__(self, limits: MoveLimits, settling: Settling) -> None:
        self.limits = limits
        self.settling = settling
        self.goal: Aim | None = None

    def start(self, target: Aim, odometry: Odometry | None, wall_ns: int) -> Aim | None:
        """The new goal, from the head's pose now; None (no move) without odometry."""
        if odometry is None:
            return None
        head_rad = (odometry.pan_rad, odometry.tilt_rad)
        self.goal = arrival_aim(target, head_rad, wall_ns, self.limits, self.settling.settle_s)
        self.settling.restart()
        return self.goal

    def over(self, odometry: Odometry | None, mono_s: float) -> bool:
        """Settled on the goal."""
        assert self.goal is not None
        return self.settling.settled(odometry, (self.goal.pan_rad, self.goal.tilt_rad), mono_s)
