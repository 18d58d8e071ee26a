"""The rig description: one TOML file, one pydantic model per section (a module each).

`load_rig(path)` returns a validated, frozen `Rig` or raises `RigError` carrying every problem
found, each as `FILE: KEY.PATH: what was wrong (expected …)` (`errors.py`). Unknown keys are
errors with a "did you mean" suggestion; TOML syntax errors carry line and column.
`load_rig_or_exit(path)` is the loader of every command and process: a bad rig prints its
problems and exits 2.

Units are in the key names (`_deg`, `_m`, `_ms`, `_hz`); the `Rig` keeps them as written, and
the properties that end in `_rad` / `_s` give SI values to the code inside.

Which process reads which section is declared with the processes, in `gazed.topics.PROCESSES`.
"""

from gazed.config.bus import ENDPOINT_PATTERN, LOOPBACK_HOSTS, BusSection, Endpoint
from gazed.config.calibration import CalibrationSection
from gazed.config.camera import CameraSection
from gazed.config.errors import RigError
from gazed.config.estimator import EstimatorSection
from gazed.config.gaze import GazeSection
from gazed.config.head import HeadSection
from gazed.config.loading import (
    cannot_start,
    exit_if_cannot_start,
    load_rig,
    load_rig_or_exit,
    parse_rig,
)
from gazed.config.rig import Rig, RigSection
from gazed.config.section import Section
from gazed.config.services import ServiceSpec, ServicesSection
from gazed.config.servo import (
    SERVO_LINK_KEYS,
    SERVO_MODELS,
    DigitalServo,
    DynamixelServo,
    FlirPtuServo,
    PelcoDServo,
    ServoLink,
    ServoSection,
    ViscaServo,
)
from gazed.config.sim import TRAJECTORY_NAMES, SimSection
from gazed.config.vision import VisionSection
from gazed.config.wide import WideSection
from gazed.topics import SERVICE_NAMES

__all__ = [
    "ENDPOINT_PATTERN",
    "LOOPBACK_HOSTS",
    "SERVICE_NAMES",
    "SERVO_LINK_KEYS",
    "SERVO_MODELS",
    "TRAJECTORY_NAMES",
    "BusSection",
    "CalibrationSection",
    "CameraSection",
    "DigitalServo",
    "DynamixelServo",
    "Endpoint",
    "EstimatorSection",
    "FlirPtuServo",
    "GazeSection",
    "HeadSection",
    "PelcoDServo",
    "Rig",
    "RigError",
    "RigSection",
    "Section",
    "ServiceSpec",
    "ServicesSection",
    "ServoLink",
    "ServoSection",
    "SimSection",
    "ViscaServo",
    "VisionSection",
    "WideSection",
    "cannot_start",
    "exit_if_cannot_start",
    "load_rig",
    "load_rig_or_exit",
    "parse_rig",
]
