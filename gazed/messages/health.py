"""Every process's health, and the supervisor's view of its processes."""

from __future__ import annotations

from typing import ClassVar, Literal

from pydantic import BaseModel, ConfigDict, Field

from gazed.messages.base import Message


class Health(Message):
    """About once a second from every process. Version 2 adds `subscribes` and `publishes`."""

    SCHEMA: ClassVar[str] = "gazed.Health"
    VERSION: ClassVar[int] = 2
    process: str
    pid: int = Field(ge=0)
    uptime_s: float = Field(ge=0)
    counters: dict[str, int] = Field(
        default_factory=dict, description="dropped, malformed, … since start."
    )
    rates_hz: dict[str, float] = Field(
        default_factory=dict, description="Messages per second received by key."
    )
    stage_ms: dict[str, float] = Field(
        default_factory=dict, description="Time spent in this process's stage."
    )
    notes: dict[str, str] = Field(default_factory=dict, description="State worth a person's eye.")
    subscribes: tuple[str, ...] = Field(
        default=(), description="Key suffixes the process subscribes (below gazed/<rig>/)."
    )
    publishes: tuple[str, ...] = Field(
        default=(), description="Key suffixes the process declares publishers for."
    )


class ProcessStatus(BaseModel):
    """One process as its supervisor sees it."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)
    name: str
    state: Literal["starting", "running", "backoff", "stopped", "missing", "disabled", "failed"]
    pid: int | None = None
    alive: bool = False
    restarts: int = Field(0, ge=0)
    last_exit: int | None = None
    message: str = ""


class SupervisorStatus(Message):
    """Every process's state and restarts, once a second and on every change."""

    SCHEMA: ClassVar[str] = "gazed.SupervisorStatus"
    state: Literal["starting", "running", "reloading", "stopping", "failed"]
    host: str = Field("", description="Host of this supervisor (a rig may span several).")
    rig_path: str
    processes: tuple[ProcessStatus, ...] = ()
    message: str = ""
