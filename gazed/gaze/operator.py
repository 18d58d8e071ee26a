"""An operator's commands to the gaze controller: park, search, hold and resume (`gaze/command`,
from the live view's buttons or `gazed operate`).

- park: the head goes to the park pose and stays there, following nobody, until resume or
  search;
- search: the search for a target starts now (the controller's own `search` state);
- hold: the head stays still where it is, following nobody, until resume; the estimates of the
  tracks and the choice of target go on;
- resume: normal following again, from a search that takes up the target in view; without a
  park or hold to end, the state is unchanged.

Park and hold override the state machine: while one is on, the controller's tick asks this
module for the demand instead of the state's handler. Every command is answered on `gaze/state`
with the reason `operator: <command>`, also one that changes no state, so that whoever sent it
(`gazed operate`, the page) sees it taken.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

from gazed.gaze.decision import state_message
from gazed.gaze.demand import make_demand
from gazed.gaze.target_choice import OPERATOR
from gazed.messages import GazeDemand, GazeStateName

if TYPE_CHECKING:
    from gazed.gaze.controller import GazeController

OPERATOR_COMMANDS = ("park", "search", "hold", "resume")
Override = Literal["park", "hold"]


@dataclass(frozen=True)
class OperatorOrder:
    """What a command does: the override it leaves on (None: the state machine runs), the state
    to be in, and the reason published with it."""

    override: Override | None
    state: GazeStateName
    reason: str


def order_for(command: str, state: GazeStateName, override: Override | None) -> OperatorOrder:
    """The order of an operator's `command` given the controller's `state` and override."""
    reason = f"{OPERATOR}: {command}"
    if command == "park":
        return OperatorOrder("park", "park", reason)
    if command == "hold":
        return OperatorOrder("hold", "hold", reason)
    if command == "search" or override is not None:  # search, or a resume that ends an override
        return OperatorOrder(None, "search", reason)
    if command == "resume":
        return OperatorOrder(None, state, reason)  # already following: nothing to end
    raise ValueError(f"not an operator's command: {command!r} (one of {OPERATOR_COMMANDS})")


class OperatorControl:
    """The operator's override of one controller; `handler` is the tick's handler while it is
    on."""

    def __init__(self, controller: GazeController) -> None:
        self.controller = controller
        self.override: Override | None = None

    def on_command(self, command: str, wall_ns: int, mono_s: float) -> bool:
        """Act on `command` if it is an operator's (True); any other (a trace, which takes over
        the head) ends the override (False)."""
        if command not in OPERATOR_COMMANDS:
            self.override = None
            return False
        c = self.controller
        order = order_for(command, c.state, self.override)
        self.override = order.override
        if order.state == c.state:  # answered all the same, with the state unchanged
            c.pending.append(
                state_message(c.state, c.state, order.reason, c.choice.target_id, wall_ns)
            )
        else:
            c.enter(order.state, order.reason, wall_ns, mono_s)
        return True

    @property
    def handler(self) -> Callable[[int, float], GazeDemand | None] | None:
        """The demand of the override on (park or hold), or None when the state machine runs."""
        return None if self.override is None else self._demand

    def _demand(self, wall_ns: int, _mono_s: float) -> GazeDemand | None:
        c = self.controller
        if self.override == "park":
            return make_demand("park", *c.park, wall_ns)
        return c.hold.demand(c.odometry, wall_ns)
