"""The controller's `trace` state: a `trace` command's line tracer (`trace`) run as a state of
the gaze, from the command until the trace ends, and the result it ends with (published once,
by the tick that ends it)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from gazed.gaze.demand import make_demand
from gazed.messages import GazeDemand, TraceResult

if TYPE_CHECKING:
    from gazed.gaze.controller import GazeController


class TraceState:
    """The trace state of one controller; `finished` holds a result not yet published."""

    def __init__(self, controller: GazeController) -> None:
        self.controller = controller
        self.finished: TraceResult | None = None

    def demand(self, wall_ns: int, mono_s: float) -> GazeDemand | None:
        """The state's handler: the tracer's goal, or the end of the trace (then search)."""
        c = self.controller
        job = c.tracer.job
        if job is None:
            c.enter("search", "no line to trace", wall_ns, mono_s)
            return c.hold.demand(c.odometry, wall_ns)
        ended = c.tracer.step(c.odometry, wall_ns, mono_s)
        if ended is not None:
            return self.finish(ended, wall_ns, mono_s)
        return make_demand("position", *job.goal_rad, wall_ns)

    def finish(self, reason: str, wall_ns: int, mono_s: float) -> GazeDemand | None:
        """End the trace for `reason`: its result is kept for the tick, and the gaze searches."""
        c = self.controller
        result = self.finished = c.tracer.end(reason, wall_ns)
        samples = len(result.samples_rad)
        c.enter("search", f"trace ended: {reason} ({samples} samples)", wall_ns, mono_s)
        return c.hold.demand(c.odometry, wall_ns)

    def take_finished(self) -> TraceResult | None:
        """The result of a trace ended since the last call, once."""
        result, self.finished = self.finished, None
        return result
