"""Every key on the bus in one place: its payload model, and which process publishes and reads it.

Keys are `gazed/<rig>/<suffix>`; liveliness tokens are `gazed/<rig>/alive/<process>/<pid>`
(the pid tells one run of a process from its restart); every process also publishes
`gazed/<rig>/<process>/health`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from gazed.messages import (
    Candidates,
    Detection,
    EdgeObservation,
    EstimatorState,
    FrameHeader,
    GazeCommand,
    GazeDemand,
    GazeSelect,
    GazeState,
    Health,
    ManeuverEvent,
    Message,
    Odometry,
    Prediction,
    ServoStatus,
    SimTruth,
    SupervisorStatus,
    TraceResult,
)

PREFIX = "gazed"
PID = re.compile(r"[1-9][0-9]*")


@dataclass(frozen=True)
class Topic:
    """One key: `suffix` below `gazed/<rig>/` and the model of its payload.

    `frames` topics carry raw pixels in the payload and the model (a `FrameHeader`) in the
    attachment; their subscribers keep only the newest sample. Who publishes and reads a topic is
    declared once, in `PROCESSES` and `TOOLS` below.
    """

    suffix: str
    model: type[Message]
    summary: str
    frames: bool = False

    def key(self, rig: str) -> str:
        return f"{PREFIX}/{rig}/{self.suffix}"


SIM_FRAME = Topic("sim/frame", FrameHeader, "rendered camera frames", frames=True)
SIM_TRUTH = Topic("sim/truth", SimTruth, "the simulated target and head at each capture")
VISION_DETECTION = Topic(
    "vision/detection", Detection, "the target's pixel and image velocity, every frame"
)
VISION_CANDIDATES = Topic("vision/candidates", Candidates, "peripheral movers, saccade targets")
VISION_EDGE = Topic("vision/edge", EdgeObservation, "the edge under the fovea while tracing")
ESTIMATOR_STATE = Topic(
    "estimator/state",
    EstimatorState,
    "every track with its appearance, and the chosen one's state, covariance and model "
    "probabilities",
)
ESTIMATOR_PREDICTION = Topic(
    "estimator/prediction", Prediction, "gaze angles and rates when the next demand acts"
)
ESTIMATOR_EVENT = Topic("estimator/event", ManeuverEvent, "the most likely motion model changed")
GAZE_DEMAND = Topic("gaze/demand", GazeDemand, "joint angles and rates for the head")
GAZE_STATE = Topic(
    "gaze/state", GazeState, "each state transition or change of target, with its reason"
)
GAZE_SELECT = Topic("gaze/select", GazeSelect, "an operator's choice of target")
GAZE_COMMAND = Topic(
    "gaze/command",
    GazeCommand,
    "requests to the controller: trace a line; park, search, hold, resume",
)
GAZE_TRACE = Topic("gaze/trace", TraceResult, "the samples of a traced ground line")
SERVO_ODOMETRY = Topic("servo/odometry", Odometry, "the head's angles and rates when read")
SERVO_STATUS = Topic("servo/status", ServoStatus, "link state, holding, errors, response lag")
# Each demand as written to the head (limited), its stamps ending ("servo", t) at the moment its
# bytes were written: the end of the loop for `gazed latency` and `gazed eval loop`.
SERVO_COMMAND = Topic("servo/command", GazeDemand, "each demand as written, stamped at the write")
SUPERVISOR_STATUS = Topic(
    "supervisor/status", SupervisorStatus, "every process's state and restarts"
)

TOPICS: tuple[Topic, ...] = (
    SIM_FRAME,
    SIM_TRUTH,
    VISION_DETECTION,
    VISION_CANDIDATES,
    VISION_EDGE,
    ESTIMATOR_STATE,
    ESTIMATOR_PREDICTION,
    ESTIMATOR_EVENT,
    GAZE_DEMAND,
    GAZE_STATE,
    GAZE_SELECT,
    GAZE_COMMAND,
    GAZE_TRACE,
    SERVO_ODOMETRY,
    SERVO_STATUS,
    SERVO_COMMAND,
    SUPERVISOR_STATUS,
)


@dataclass(frozen=True)
class Process:
    """A participant on the bus: the topics it reads and publishes and, for the rig's processes,
    the rig sections it reads besides `[rig]` and `[bus]` (a SIGHUP that changes one of them
    restarts it). This is the one declaration of the contract: the services subscribe and
    publish from it, the docs' table is generated from it, and tests check both against it."""

    name: str
    summary: str
    reads: tuple[Topic, ...]
    publishes: tuple[Topic, ...]
    sections: tuple[str, ...] = ()


# The rig's processes, started by the supervisor as `python -m services.<name>`, in start order.
PROCESSES: tuple[Process, ...] = (
    Process(
        "sim",
        "the simulated world: target, head emulator on a pty, camera renderer",
        reads=(),
        publishes=(SIM_FRAME, SIM_TRUTH),
        sections=("camera", "head", "servo", "sim", "calibration"),
    ),
    Process(
        "servo",
        "the link to the head: limits, set-points, odometry, park",
        reads=(GAZE_DEMAND,),
        publishes=(SERVO_ODOMETRY, SERVO_STATUS, SERVO_COMMAND),
        sections=("head", "servo"),
    ),
    Process(
        "vision",
        "the camera and the detector",
        reads=(SIM_FRAME, SERVO_ODOMETRY, GAZE_STATE),
        publishes=(VISION_DETECTION, VISION_CANDIDATES, VISION_EDGE),
        sections=("camera", "head", "vision", "servo", "wide"),
    ),
    Process(
        "estimator",
        "ground-plane geometry, the motion filters, prediction over the latency",
        reads=(VISION_DETECTION, SERVO_COMMAND, SERVO_STATUS, GAZE_STATE),
        publishes=(ESTIMATOR_STATE, ESTIMATOR_PREDICTION, ESTIMATOR_EVENT),
        sections=("camera", "head", "calibration", "estimator"),
    ),
    Process(
        "gaze",
        "the saccade/pursuit state machine",
        reads=(
            ESTIMATOR_PREDICTION,
            VISION_DETECTION,
            VISION_CANDIDATES,
            SERVO_ODOMETRY,
            GAZE_COMMAND,
            VISION_EDGE,
            ESTIMATOR_STATE,
            GAZE_SELECT,
        ),
        publishes=(GAZE_DEMAND, GAZE_STATE, GAZE_TRACE),
        sections=("camera", "head", "calibration", "gaze"),
    ),
)

# The supervisor and the command-line tools that take part in the contract. `gazed tail`,
# `gazed status` and `gazed latency` read any key (`gazed/<rig>/**`) and are not listed.
TOOLS: tuple[Process, ...] = (
    Process(
        "gazed run",
        "the supervisor: starts and watches the processes; its console line",
        reads=(GAZE_STATE, ESTIMATOR_STATE, SERVO_COMMAND),
        publishes=(SUPERVISOR_STATUS,),
    ),
    Process(
        "gazed calibrate trace",
        "traces ground lines with the running rig",
        reads=(GAZE_TRACE,),
        publishes=(GAZE_COMMAND,),
    ),
    Process(
        "gazed view",
        "the live view in the browser (also under `gazed run` with a [view])",
        reads=(
            SIM_FRAME,
            SERVO_ODOMETRY,
            VISION_DETECTION,
            VISION_CANDIDATES,
            ESTIMATOR_STATE,
            ESTIMATOR_PREDICTION,
            GAZE_STATE,
            SERVO_COMMAND,
        ),
        publishes=(GAZE_SELECT, GAZE_COMMAND),
    ),
    Process(
        "gazed operate",
        "an operator's park, search, hold or resume",
        reads=(GAZE_STATE,),
        publishes=(GAZE_COMMAND,),
    ),
    Process(
        "gazed select",
        "an operator's choice of the track to follow",
        reads=(SERVO_ODOMETRY, GAZE_STATE),
        publishes=(GAZE_SELECT,),
    ),
    Process(
        "gazed eval loop",
        "scores the running loop against the simulator's truth or the footage's annotations",
        reads=(
            SIM_TRUTH,
            VISION_DETECTION,
            GAZE_STATE,
            SERVO_COMMAND,
            ESTIMATOR_STATE,
            SERVO_STATUS,
            SUPERVISOR_STATUS,
        ),
        publishes=(GAZE_SELECT,),
    ),
)

SERVICE_NAMES: tuple[str, ...] = tuple(p.name for p in PROCESSES)


def process(name: str) -> Process:
    """The declaration of one of the rig's processes."""
    for candidate in PROCESSES:
        if candidate.name == name:
            return candidate
    raise KeyError(f"no process named {name!r}")


def publishers_of(topic: Topic) -> tuple[str, ...]:
    return tuple(p.name for p in (*PROCESSES, *TOOLS) if topic in p.publishes)


def readers_of(topic: Topic) -> tuple[str, ...]:
    return tuple(p.name for p in (*PROCESSES, *TOOLS) if topic in p.reads)


def health(process: str) -> Topic:
    """`<process>/health`, published by every process about once a second."""
    return Topic(f"{process}/health", Health, "counters, receive rates and stage times")


def alive_key(rig: str, process: str = "*", pid: int | str = "*") -> str:
    """Liveliness token of the run `pid` of a process; `*` matches every process, or every
    run, and `pid="**"` also the keys that are not a token's.

    The pid is in the key so that a token of a process that has died, arriving late (a
    peer's links change as it dies), is never taken for its restart's."""
    return f"{PREFIX}/{rig}/alive/{process}/{pid}"


def split_alive_key(key: str) -> tuple[str, str, int] | None:
    """`gazed/<rig>/alive/<process>/<pid>` -> (rig, process, pid); None for any other key (a
    pid is a positive decimal number, ASCII digits without a leading zero)."""
    parts = key.split("/")
    if len(parts) != 5 or parts[0] != PREFIX or parts[2] != "alive" or not PID.fullmatch(parts[4]):
        return None
    return parts[1], parts[3], int(parts[4])


def split_key(key: str) -> tuple[str, str] | None:
    """`gazed/<rig>/<suffix>` -> (rig, suffix); None for keys that are not gazed's."""
    parts = key.split("/", 2)
    if len(parts) != 3 or parts[0] != PREFIX:
        return None
    return parts[1], parts[2]


def topic_for(suffix: str) -> Topic | None:
    """The topic of a key suffix, health keys included."""
    for topic in TOPICS:
        if topic.suffix == suffix:
            return topic
    process, _, leaf = suffix.partition("/")
    if leaf == "health" and process:
        return health(process)
    return None
