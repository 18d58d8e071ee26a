"""`gazed operate --rig RIG {park,search,hold,resume}`: an operator's command to the running rig's
gaze, as the live view's buttons send it.

Publishes one `GazeCommand` on `gaze/command` and waits for the gaze's answer on `gaze/state`
(the reason `operator: <command>`): park sends the head to its park pose and keeps it there,
search starts the search for a target now, hold keeps the head still where it is, resume goes
back to following (`gazed.gaze.operator`). Exit 0 when the gaze answered, 1 when no gaze
process is there or it did not answer in time, 2 for a bad rig.
"""

from __future__ import annotations

import argparse
import sys
import time
import uuid
from pathlib import Path

from gazed.bus import BusError
from gazed.bustools.gaze_answer import gaze_answer, gaze_listens
from gazed.bustools.tool_session import tool_session
from gazed.config import load_rig_or_exit
from gazed.gaze.operator import OPERATOR_COMMANDS
from gazed.gaze.target_choice import OPERATOR
from gazed.messages import GazeCommand
from gazed.topics import GAZE_COMMAND, GAZE_STATE


def operate_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--rig", type=Path, required=True, help="the running rig's file")
    parser.add_argument(
        "command",
        choices=OPERATOR_COMMANDS,
        help="park: to the park pose and stay; search: search now; hold: keep the head still; "
        "resume: follow again",
    )
    parser.add_argument(
        "--timeout-s", type=float, default=5.0, help="how long to wait for the gaze's answer"
    )


def operate_command(args: argparse.Namespace) -> int:
    rig = load_rig_or_exit(args.rig)
    request = GazeCommand(
        t_capture_ns=time.time_ns(),
        command=args.command,
        request_id=f"operate-{uuid.uuid4().hex[:8]}",
    )
    try:
        with tool_session(rig, "operate") as (bus, wakeup):
            answers = bus.subscribe(GAZE_STATE, capacity=64)
            publisher = bus.publisher(GAZE_COMMAND)
            deadline = time.monotonic() + args.timeout_s
            if not gaze_listens(publisher, wakeup, deadline):
                print(f"gazed operate: no gaze process of rig '{rig.name}'", file=sys.stderr)
                return 1
            publisher.put(request)
            reason = f"{OPERATOR}: {args.command}"  # the gaze took the command
            answer = gaze_answer(answers, lambda s: s.reason == reason, wakeup, deadline)
    except BusError as exc:  # NoRunningRig says which rig and what to check
        print(f"gazed operate: {exc}", file=sys.stderr)
        return 1
    if answer is None:
        print(
            f"gazed operate: the gaze did not answer within {args.timeout_s:g} s", file=sys.stderr
        )
        return 1
    print(f"{answer.previous} -> {answer.state}: {answer.reason}")
    return 0
