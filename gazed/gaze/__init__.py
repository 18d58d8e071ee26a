"""Gaze control: the saccade/pursuit state machine and where to point (DESIGN §7).

`controller` is the state machine. The parts it drives, each holding the state of its concern:
`sightings` (what vision has shown), `move` (a ballistic move and its settling, aimed by
`aim.arrival_aim`), `pursuit`, `look_and_move`, `lost_search`, `trace` and `demand` (limits and
the hold). `schedule` says when the `gaze` process ticks the controller.
"""

STAGE = "gaze"  # this process's name in a message's stamps
FUTURE_TOLERANCE_NS = 500_000_000  # a message stamped further ahead of our clock is bogus
