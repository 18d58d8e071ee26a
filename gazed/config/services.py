"""`[services]`: which of the rig's processes run, and the supervisor's restart policy."""

from __future__ import annotations

from pydantic import Field

from gazed.config.section import Section


class ServiceSpec(Section):
    enabled: bool = Field(True, description="Start this process.")
    module: str | None = Field(
        None,
        pattern=r"^[A-Za-z_][A-Za-z0-9_.]*$",
        description="Python module run as `python -m MODULE --rig RIG` (default services.<name>); "
        "the process it starts holds the liveliness token (`gazed.bus.Bus.declare_alive`).",
    )


class ServicesSection(Section):
    sim: ServiceSpec = Field(
        default_factory=ServiceSpec, description="The simulated world and head emulator."
    )
    servo: ServiceSpec = Field(
        default_factory=ServiceSpec, description="The serial link to the head."
    )
    vision: ServiceSpec = Field(
        default_factory=ServiceSpec, description="Camera source and detector."
    )
    estimator: ServiceSpec = Field(
        default_factory=ServiceSpec, description="Ground-plane filter and prediction."
    )
    gaze: ServiceSpec = Field(
        default_factory=ServiceSpec, description="Saccade/pursuit state machine."
    )
    restart_max: int = Field(
        5,
        ge=1,
        le=1000,
        description="Restarts of one process within restart_window_s "
        "before the supervisor gives up.",
    )
    restart_window_s: float = Field(60.0, gt=0, description="Window of the restart intensity.")
    backoff_initial_s: float = Field(
        0.1, ge=0, le=60, description="First restart delay; doubles on each restart."
    )
    backoff_max_s: float = Field(10.0, gt=0, le=600, description="Longest restart delay.")
    stop_grace_s: float = Field(
        3.0, gt=0, le=120, description="SIGTERM to SIGKILL grace period on stop."
    )
    ready_timeout_s: float = Field(
        30.0,
        gt=0,
        le=600,
        description="A started process that shows no liveliness within this is restarted.",
    )

    def spec(self, name: str) -> ServiceSpec:
        return getattr(self, name)
