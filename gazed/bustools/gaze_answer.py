"""What `gazed select` and `gazed operate` share: wait for the gaze to listen on the topic the
request goes to, then for its answer on `gaze/state`."""

from __future__ import annotations

import time
from collections.abc import Callable

from gazed.bus import Publisher, Subscription
from gazed.messages import GazeState
from gazed.wakeup import Wakeup

POLL_S = 0.05  # between looks, when no sample woke us


def gaze_listens(publisher: Publisher, wakeup: Wakeup, deadline: float) -> bool:
    """True once a gaze process subscribes to `publisher`'s key; False at monotonic `deadline`."""
    while not publisher.matched():
        if time.monotonic() > deadline:
            return False
        wakeup.wait(POLL_S)
    return True


def gaze_answer(
    answers: Subscription[GazeState],
    is_answer: Callable[[GazeState], bool],
    wakeup: Wakeup,
    deadline: float,
) -> GazeState | None:
    """The first gaze/state that `is_answer` accepts; None at monotonic `deadline`."""
    while time.monotonic() < deadline:
        for state in answers.take():
            if is_answer(state):
                return state
        wakeup.wait(POLL_S)
    return None
