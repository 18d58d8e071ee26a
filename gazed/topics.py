"""Every key on the bus in one place: its payload model, who publishes it and who reads it.

Keys are `gazed/<rig>/<suffix>`; liveliness tokens are `gazed/<rig>/alive/<process>`; every
process also publishes `gazed/<rig>/<process>/health`.
"""

from __future__ import annotations

from dataclasses import dataclass

from gazed.messages import (
    Candidates,
    Detection,
    EdgeObservation,
    EstimatorState,
    FrameHeader,
    GazeCommand,
    GazeDemand,
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


@dataclass(frozen=True)
class Topic:
    """One key: `suffix` below `gazed/<rig>/`, the model of its payload, its publisher and readers.

    `frames` topics carry raw pixels in the payload and the model (a `FrameHeader`) in the
    attachment; their subscribers keep only the newest sample.
    """

    suffix: str
    model: type[Message]
    publisher: str
    readers: tuple[str, ...]
    frames: bool = False

    def key(self, rig: str) -> str:
        return f"{PREFIX}/{rig}/{self.suffix}"


SIM_FRAME = Topic("sim/frame", FrameHeader, "sim", ("vision",), frames=True)
SIM_TRUTH = Topic("sim/truth", SimTruth, "sim", ("gazed eval",))
VISION_DETECTION = Topic("vision/detection", Detection, "vision", ("estimator", "gaze"))
VISION_CANDIDATES = Topic("vision/candidates", Candidates, "vision", ("gaze",))
ESTIMATOR_STATE = Topic("estimator/state", EstimatorState, "estimator", ("gazed tail",))
ESTIMATOR_PREDICTION = Topic("estimator/prediction", Prediction, "estimator", ("gaze",))
ESTIMATOR_EVENT = Topic("estimator/event", ManeuverEvent, "estimator", ("gazed tail",))
GAZE_DEMAND = Topic("gaze/demand", GazeDemand, "gaze", ("servo",))
GAZE_STATE = Topic("gaze/state", GazeState, "gaze", ("vision", "gazed run"))
GAZE_COMMAND = Topic("gaze/command", GazeCommand, "gazed calibrate trace", ("gaze",))
GAZE_TRACE = Topic("gaze/trace", TraceResult, "gaze", ("gazed calibrate trace",))
VISION_EDGE = Topic("vision/edge", EdgeObservation, "vision", ("gaze",))
SERVO_ODOMETRY = Topic("servo/odometry", Odometry, "servo", ("vision", "gaze"))
SERVO_STATUS = Topic("servo/status", ServoStatus, "servo", ("gazed status", "estimator"))
# Each demand as written to the head (limited), its stamps ending ("servo", t) at the moment its
# bytes were written: the end of the loop for `gazed latency` and `gazed eval loop`.
SERVO_COMMAND = Topic("servo/command", GazeDemand, "servo", ("gazed latency", "estimator"))
SUPERVISOR_STATUS = Topic("supervisor/status", SupervisorStatus, "supervisor", ("gazed status",))

TOPICS: tuple[Topic, ...] = (
    SIM_FRAME,
    SIM_TRUTH,
    VISION_DETECTION,
    VISION_CANDIDATES,
    ESTIMATOR_STATE,
    ESTIMATOR_PREDICTION,
    ESTIMATOR_EVENT,
    GAZE_DEMAND,
    GAZE_STATE,
    GAZE_COMMAND,
    GAZE_TRACE,
    VISION_EDGE,
    SERVO_ODOMETRY,
    SERVO_STATUS,
    SERVO_COMMAND,
    SUPERVISOR_STATUS,
)


def health(process: str) -> Topic:
    """`<process>/health`, published by every process about once a second."""
    return Topic(f"{process}/health", Health, process, ("gazed status",))


def alive_key(rig: str, process: str = "*") -> str:
    """Liveliness token of a process (`*` for all of a rig's)."""
    return f"{PREFIX}/{rig}/alive/{process}"


def rig_keys(rig: str = "*") -> str:
    """Every key of a rig (`*` for every rig on the bus)."""
    return f"{PREFIX}/{rig}/**"


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
