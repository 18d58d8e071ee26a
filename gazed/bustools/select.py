"""`gazed select --rig RIG (--track ID | --ground X Y | --pixel U V | --rule)`: choose the person
the running rig follows.

Publishes one `GazeSelect` on `gaze/select` and waits for the gaze's answer on `gaze/state`:
the track it now follows and why, or why it refused (no such track). `--pixel` is a pixel of
the head's view; the head pose it was seen at is `--pose PAN_DEG TILT_DEG`, or else the head's
pose now (from `servo/odometry`). `--rule` hands the choice back to the rig's `[gaze]
select_rule`. Exit 0 when the gaze took the choice, 1 when it refused or did not answer in
time, 2 for a bad rig.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from gazed.bus import BusError, Subscription
from gazed.bustools.gaze_answer import POLL_S, gaze_answer, gaze_listens
from gazed.bustools.tool_session import tool_session
from gazed.config import load_rig_or_exit
from gazed.gaze.target_choice import OPERATOR, REFUSED
from gazed.messages import GazeSelect, GazeState, HeadPose, Odometry
from gazed.topics import GAZE_SELECT, GAZE_STATE, SERVO_ODOMETRY
from gazed.wakeup import Wakeup


def select_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--rig", type=Path, required=True, help="the running rig's file")
    choice = parser.add_mutually_exclusive_group(required=True)
    choice.add_argument("--track", type=int, metavar="ID", help="follow the track with this id")
    choice.add_argument(
        "--ground",
        type=float,
        nargs=2,
        metavar=("X", "Y"),
        help="the confirmed track of the person there (m); held until one is confirmed, "
        "at most the rig's track start-up (docs/gaze.md)",
    )
    choice.add_argument(
        "--pixel", type=float, nargs=2, metavar=("U", "V"), help="the track nearest this pixel"
    )
    choice.add_argument("--rule", action="store_true", help="back to the rig's select_rule")
    parser.add_argument(
        "--pose",
        type=float,
        nargs=2,
        metavar=("PAN_DEG", "TILT_DEG"),
        help="the head pose --pixel was seen at (default: the head's pose now)",
    )
    parser.add_argument(
        "--timeout-s", type=float, default=5.0, help="how long to wait for the gaze's answer"
    )


def select_command(args: argparse.Namespace) -> int:
    rig = load_rig_or_exit(args.rig)
    values = [*(args.ground or ()), *(args.pixel or ()), *(args.pose or ())]
    if not all(map(math.isfinite, values)) or (args.track is not None and args.track < 0):
        print("gazed select: the track id, point, pixel and pose must be finite", file=sys.stderr)
        return 2
    try:
        with tool_session(rig, "select") as (bus, wakeup):
            answers = bus.subscribe(GAZE_STATE, capacity=64)
            odometry = bus.subscribe(SERVO_ODOMETRY, capacity=4)
            publisher = bus.publisher(GAZE_SELECT)
            deadline = time.monotonic() + args.timeout_s
            if not gaze_listens(publisher, wakeup, deadline):
                print(f"gazed select: no gaze process of rig '{rig.name}'", file=sys.stderr)
                return 1
            request = _request(args, odometry, wakeup, deadline)
            if request is None:
                print("gazed select: no head pose on servo/odometry; give --pose", file=sys.stderr)
                return 1
            publisher.put(request)
            answer = gaze_answer(answers, _about_a_choice, wakeup, deadline)
    except BusError as exc:  # NoRunningRig says which rig and what to check
        print(f"gazed select: {exc}", file=sys.stderr)
        return 1
    if answer is None:
        print(f"gazed select: the gaze did not answer within {args.timeout_s:g} s", file=sys.stderr)
        return 1
    print(f"target {answer.target_id}: {answer.reason}")
    return 1 if answer.reason.startswith(REFUSED) else 0


def _request(
    args: argparse.Namespace, odometry: Subscription[Odometry], wakeup: Wakeup, deadline: float
) -> GazeSelect | None:
    """The request the arguments make; None when a pixel needs a pose nobody gave."""
    now_ns = time.time_ns()
    if args.track is not None:
        return GazeSelect(t_capture_ns=now_ns, track_id=args.track)
    if args.ground is not None:
        return GazeSelect(t_capture_ns=now_ns, ground_xy_m=tuple(args.ground))
    if args.pixel is None:
        return GazeSelect(t_capture_ns=now_ns)  # --rule
    if args.pose is not None:
        pan_deg, tilt_deg = args.pose
        head = HeadPose(pan_rad=math.radians(pan_deg), tilt_rad=math.radians(tilt_deg))
    else:
        latest = None
        while latest is None and time.monotonic() < deadline:
            latest = odometry.latest()
            wakeup.wait(POLL_S)
        if latest is None:
            return None
        head = HeadPose(pan_rad=latest.pan_rad, tilt_rad=latest.tilt_rad)
    return GazeSelect(t_capture_ns=now_ns, pixel_px=tuple(args.pixel), head=head)


def _about_a_choice(state: GazeState) -> bool:
    """The gaze's gaze/state about an operator's request."""
    return state.reason.startswith(OPERATOR)
