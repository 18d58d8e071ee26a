"""What vision has shown of the target: its latest detection with the run of frames in a row
that have shown it, and the latest whole-frame motion candidates with the run of frames in a
row, from a head at rest, whose best candidate has a measured image velocity.

A detection is taken up only after `reacquire_detections` in a row, so that a lone false
detection draws no move. Candidates are searched only in frames taken from a head at rest: a
turning head's compensation residue looks like motion too.

How old a sighting is (`age_ns`) is counted in the frames vision has reported on, not on the
wall clock: a frame reaches the gaze its pipeline's lag after its capture (the camera's delay,
vision's work, the bus), so on the wall clock every sighting is that lag old on arrival, and
`lost_after_ms` would run out after a shorter absence the longer the camera's latency (at once
past it). The lag is that of the newest frame when it came in (`arrived`); while vision is
silent the age still grows with the wall clock from there.
"""

from __future__ import annotations

from gazed.config import GazeSection
from gazed.gaze import FUTURE_TOLERANCE_NS
from gazed.gaze.aim import Aim, detection_aim, image_aim
from gazed.gaze.move import at_rest
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.zoom import ZoomLens
from gazed.messages import Candidates, Detection

RUN_GAP_FRAMES = 2.5  # a detection this many frame periods after the last still continues a run
# A motion candidate's image velocity is vision's fit over its region's recent centroids
# (`gazed.vision.candidates.VELOCITY_POINTS`): none in the frame a region first shows, far off
# over two frames. A saccade aims with that velocity over a horizon H (the visual latency, the
# move and its settling), so a candidate draws one only once this many frames in a row have
# measured its velocity: the fit's whole window. The wait is counted in frames, not seconds: a
# least-squares slope over n centroids, each known to σ, errs by σ·sqrt(12 / (n(n²-1))) / T at
# frame period T, so over H it adds no more than the position's own σ once
# n(n²-1) / 12 >= (H/T)². At the camera rates in use, a saccade across a good part of the view
# spans enough frame periods for that to ask for the whole window or more, and only the shortest
# saccades at the slowest cameras would be allowed a frame less: a shorter wait would aim with a
# velocity whose error over the move outweighs the position's.
CANDIDATE_VELOCITY_FRAMES = 5


class Sightings:
    """`found`: the latest detection of the target taken into account; `in_a_row`: how many
    consecutive frames have shown it since the run was last restarted; `candidates`: the
    latest motion candidates; `measured_in_a_row`: how many consecutive candidate frames, from a
    head at rest, have given their best candidate an image velocity; `turning_candidates`
    counts those seen from a turning head."""

    def __init__(
        self,
        gaze: GazeSection,
        frame_period_s: float,
        lens: ZoomLens,
        kinematics: HeadKinematics,
    ) -> None:
        self.frame_period_s = frame_period_s
        self.max_age_ms = gaze.lost_after_ms
        self.candidate_min_score = gaze.candidate_min_score
        self.lens = lens
        self.kinematics = kinematics
        self.found: Detection | None = None
        self.in_a_row = 0
        self.candidates: Candidates | None = None
        self.measured_in_a_row = 0
        self.turning_candidates = 0
        self.newest_frame_ns: int | None = None  # the newest frame vision has reported on
        self.frame_lag_ns = 0  # how long after its capture it came in

    def arrived(self, t_capture_ns: int, wall_ns: int) -> None:
        """Vision reported on a frame captured at `t_capture_ns`, found or not, at `wall_ns`:
        the newest one sets the lag (one stamped implausibly far in the future, none)."""
        if t_capture_ns - wall_ns > FUTURE_TOLERANCE_NS:
            return
        if self.newest_frame_ns is not None and t_capture_ns <= self.newest_frame_ns:
            return
        self.newest_frame_ns = t_capture_ns
        self.frame_lag_ns = max(wall_ns - t_capture_ns, 0)

    def age_ns(self, t_capture_ns: int, wall_ns: int) -> int:
        """How long before the newest frame vision could have reported on by `wall_ns` a frame
        captured at `t_capture_ns` was taken (module docstring)."""
        return wall_ns - self.frame_lag_ns - t_capture_ns

    def fresh(self, t_capture_ns: int, wall_ns: int) -> bool:
        """Whether a frame captured at `t_capture_ns` is at most `max_age_ms` old (`age_ns`)."""
        return self.age_ns(t_capture_ns, wall_ns) / 1e6 <= self.max_age_ms

    def take(self, detection: Detection, count: bool) -> None:
        """The newest detection; with `count`, it extends the run first."""
        if count:
            self._count(detection)
        self.found = detection

    def on_candidates(self, candidates: Candidates) -> None:
        """The newest candidates; a frame whose best candidate has no velocity (a region seen
        for the first time, or merged or split, (0, 0) from vision) or seen from a turning head
        restarts the run (a repeat of a frame counts nothing)."""
        previous, self.candidates = self.candidates, candidates
        if previous is not None and candidates.t_capture_ns <= previous.t_capture_ns:
            return
        best = max(candidates.candidates, key=lambda k: k.score, default=None)
        measured = (
            candidates.head is not None
            and at_rest(candidates.head)
            and best is not None
            and (best.du_px_s, best.dv_px_s) != (0.0, 0.0)
        )
        self.measured_in_a_row = self.measured_in_a_row + 1 if measured else 0

    def restart_run(self) -> None:
        self.in_a_row = 0

    def forget(self) -> None:
        """Only detections from after now count (the head has just moved)."""
        self.found = None

    def aim(self, detection: Detection) -> Aim:
        """Where a detection says the target is, at its capture."""
        return detection_aim(self.lens, self.kinematics, detection)

    def recent(self, wall_ns: int, since_ns: int) -> Detection | None:
        """The latest detection if it was captured since `since_ns`, at most `max_age_ms` old
        (`age_ns`) and not implausibly far in the future."""
        d = self.found
        if d is None or d.t_capture_ns < since_ns or d.t_capture_ns - wall_ns > FUTURE_TOLERANCE_NS:
            return None
        if not self.fresh(d.t_capture_ns, wall_ns):
            return None
        return d

    def best_candidate(self, wall_ns: int, since_ns: int) -> Aim | None:
        """The strongest motion candidate of the latest frame, if it was captured since
        `since_ns`, at most `max_age_ms` old, from a head at rest, scores at least
        `candidate_min_score`, and ends a run of CANDIDATE_VELOCITY_FRAMES frames with a
        measured velocity."""
        c = self.candidates
        if c is None or c.head is None or not c.candidates or c.t_capture_ns < since_ns:
            return None
        if not self.fresh(c.t_capture_ns, wall_ns):
            return None
        if not at_rest(c.head):
            self.turning_candidates += 1
            return None
        best = max(c.candidates, key=lambda k: k.score)
        if best.score < self.candidate_min_score:
            return None
        if self.measured_in_a_row < CANDIDATE_VELOCITY_FRAMES:
            return None
        return image_aim(
            self.lens.at_pose(c.head),
            self.kinematics,
            c.head,
            c.t_capture_ns,
            (best.u_px, best.v_px),
            (best.du_px_s, best.dv_px_s),
        )

    def _count(self, detection: Detection) -> None:
        """One more in a row if it comes a frame or two after the previous one; the first of a
        new run otherwise (a repeat of a frame counts nothing)."""
        if self.found is None:
            self.in_a_row = 1
            return
        gap_s = (detection.t_capture_ns - self.found.t_capture_ns) / 1e9
        if gap_s <= 0.0:
            return
        self.in_a_row = self.in_a_row + 1 if gap_s <= RUN_GAP_FRAMES * self.frame_period_s else 1
