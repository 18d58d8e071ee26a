"""What the gaze controller says: one tick's decision, and its gaze/state messages."""

from __future__ import annotations

from dataclasses import dataclass

from gazed.gaze import STAGE
from gazed.messages import GazeDemand, GazeState, GazeStateName, TraceResult


@dataclass(frozen=True)
class Decision:
    demand: GazeDemand | None
    transitions: tuple[GazeState, ...]  # in order: one tick can pass through several states
    trace: TraceResult | None = None

    @property
    def transition(self) -> GazeState | None:
        """The last transition of the tick (the state it ended in), if any."""
        return self.transitions[-1] if self.transitions else None


def state_message(
    state: GazeStateName,
    previous: GazeStateName,
    reason: str,
    target_id: int | None,
    wall_ns: int,
) -> GazeState:
    """A gaze/state message: a transition, or (`state` == `previous`) a change of target."""
    return GazeState(
        t_capture_ns=wall_ns,
        stamps=((STAGE, wall_ns),),
        state=state,
        previous=previous,
        reason=reason,
        target_id=target_id,
    )
