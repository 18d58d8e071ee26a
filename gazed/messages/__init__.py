"""Wire schemas: every message on the bus is one of these pydantic models, sent as JSON with the
zenoh encoding `application/json;gazed.<Name>/<version>`. One module per process that publishes
them; `gazed.messages.base` holds what they share (see its docstring for stamps and units)."""

from gazed.messages.base import ARRIVAL_STAGE, HeadPose, Message, Stamp
from gazed.messages.estimator import EstimatorState, ManeuverEvent, Prediction, Track, TrackLook
from gazed.messages.gaze import (
    GazeCommand,
    GazeDemand,
    GazeSelect,
    GazeState,
    GazeStateName,
    TraceResult,
)
from gazed.messages.head import Odometry, ServoStatus
from gazed.messages.health import Health, ProcessStatus, SupervisorStatus
from gazed.messages.sim import SimTruth
from gazed.messages.vision import (
    Candidate,
    Candidates,
    Detection,
    EdgeObservation,
    FrameHeader,
    Mover,
)

__all__ = [
    "ARRIVAL_STAGE",
    "Candidate",
    "Candidates",
    "Detection",
    "EdgeObservation",
    "EstimatorState",
    "FrameHeader",
    "GazeCommand",
    "GazeDemand",
    "GazeSelect",
    "GazeState",
    "GazeStateName",
    "HeadPose",
    "Health",
    "ManeuverEvent",
    "Message",
    "Mover",
    "Odometry",
    "Prediction",
    "ProcessStatus",
    "ServoStatus",
    "SimTruth",
    "Stamp",
    "SupervisorStatus",
    "TraceResult",
    "Track",
    "TrackLook",
]
