"""Gaze control: the saccade/pursuit state machine and where to point (DESIGN §7).

`controller` is the state machine; the other modules are the parts it drives: `aim` (where a
target is and where it will be when a move ends), `settling`, `sightings`, `residual`,
`lost_search`, `trace` and `demand`.
"""

STAGE = "gaze"  # this process's name in a message's stamps
FUTURE_TOLERANCE_NS = 500_000_000  # a message stamped further ahead of our clock is bogus
