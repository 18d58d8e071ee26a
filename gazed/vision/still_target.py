"""A target that stops, seen by its look where the flow detector last saw it move.

A motion detector sees what moves against the background. A person who stops shows it
nothing but the residue of the head poses' noise on their own texture: regions that pass the
still limit in some frames and not in others, at no steady place on the body. Without steady
sightings the gaze gives them up (`lost_after_ms`) and goes looking elsewhere while they stand
in front of the camera. But a target that stands still in the world is where it stood and looks
as it did, and the head turns about its camera's centre: the pixels of the last frame the
detector saw the target move in (the patch's frame) map onto the newest frame by the rotation
(and zoom) homography between the two poses, the product of the frame-to-frame steps since
(`reference_pair`, a `FramePair` against the patch's frame). The detector registers that pair
on the background about the target, as it does the previous frame (the two poses are each off
by their noise), and the patch is matched in the newest frame warped back onto the patch's
frame by the registered homography.

A patch is held only once its look has been seen to move. Each frame the motion detector finds
the target in, the patch is matched first: where it matched away from where it stood (beyond the
still limit), the target moves; where it did not match, the look has changed, and the count
starts again; where it matched where it stood, the patch is kept, and it ages. A patch is
`confirmed` once its look has moved in `BASELINE_FRAMES` frames in a row. A region the motion
detector finds for a frame on the background (the poses' residue on a strong edge) stands still
in the world: its look never moves, and it is never held; one frame whose head pose was off
does not make the background a target either. A move counts only where the head poses are borne
out: every step since the patch's frame from the odometry (`FramePair.compensated`; a frame with
no head pose, as at a replay's start, is taken as from a still head, and the background then
seems to move), and the background registered between the two frames where the poses have noise
(odometry that lags the frames, as a polled camera's, moves the background beyond what the
registration takes). Otherwise the count starts again. A patch whose steps are not all known is
not matched at all: a rig with no odometry does not hold a target that stops.

The patch is the target's pixels that moved with it, grown by `GROW_PX` (its outline), not its
box, so that the ground behind a target that left cannot pass for it. It is matched by
normalised correlation (`cv2.matchTemplate`, masked to those pixels, the peak refined to a
fraction of a pixel), within a radius of the registration's bound plus `SWAY_FRACTION` of the
target's size. A match counts where the correlation is at least `MIN_CORRELATION`: for a patch
against itself under independent noise the correlation is S / (S + N), S its contrast's variance
and N the noise's, so the bound asks the two views to agree with a signal-to-noise ratio of 4.
A target that walked off leaves the background behind, which its pixels do not correlate with.

The detector (`normal_flow`) asks first whether the target stands: a match within its own noise
of where the target stood (what the motion detector calls still) by a patch at least
`BASELINE_FRAMES` old (the motion detector's longer baseline, over which a slow target shows)
takes the frame, and whatever the motion detector would find on the target is residue. A target
that moves is the motion detector's, and its look moving gives a new patch each frame. Where
the motion detector finds nothing, a match anywhere within the radius holds the target (a person
who stopped and shifted their weight). A held target is reported at the matched place with the
velocity of its recent matches (the slope of the last `VELOCITY_POINTS`, the patch's own place
first), so the estimator sees a target that stopped rather than none.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from gazed.vision.detector import BASELINE_FRAMES, FramePair
from gazed.vision.ego_motion import HeadStep, apply_homography
from gazed.vision.movers import Blob, MoverRegion
from gazed.vision.position_history import PositionHistory

MIN_CORRELATION = 0.8  # S / (S + N) ≥ 0.8: the views agree with a signal-to-noise ratio of 4
SWAY_FRACTION = 0.25  # the search reaches this share of the target's larger side further
GROW_PX = 2  # the target's pixels grown by this much: its outline against the background
MIN_SIDE_PX = 5  # a patch narrower than this holds too little to match
VELOCITY_POINTS = 6  # the matches a held target's velocity is fitted to
_GROW_KERNEL = np.ones((2 * GROW_PX + 1, 2 * GROW_PX + 1), np.uint8)


@dataclass(frozen=True)
class Held:
    """The target matched in the newest frame (its point, velocity, box and area; its
    confidence the correlation), and how far (px) it is from where it stood in the patch."""

    mover: MoverRegion
    moved_px: float


class StillTarget:
    """The target's patch from the last frame the detector saw it move in, and the head's
    steps since."""

    def __init__(self) -> None:
        self._frame: np.ndarray | None = None  # the patch's frame (grey)
        self._patch = np.zeros((0, 0), np.float32)  # the target and its outline
        self._mask = np.zeros((0, 0), np.uint8)  # the target's pixels grown by GROW_PX
        self._origin = (0, 0)  # the patch's top-left pixel in its frame
        self._point = (0.0, 0.0)  # the target's point in its frame
        self._box = (0, 0, 0, 0)  # its pixels' box in its frame: left, top, right, bottom
        self._area_px = 0.0
        self._t_s = 0.0
        self._H = np.eye(3)  # the patch's frame's pixels -> the newest frame's
        self._f_px = 1.0  # the patch's frame's focal length
        self._compensated = True  # every step since the patch's frame from the odometry
        self.moves = 0  # the frames in a row its look was seen to move, up to this patch
        self.age_frames = 0  # the frames since the patch's
        # the target's recent places in the patch's frame, as shifts from where it stood
        self._shifts = PositionHistory(VELOCITY_POINTS)

    def reset(self) -> None:
        self._frame = None

    @property
    def confirmed(self) -> bool:
        """Its look was seen to move in `BASELINE_FRAMES` frames in a row: a target, not a
        fleeting residue nor a frame whose head pose was off."""
        return self.moves >= BASELINE_FRAMES

    def remember(
        self, pair: FramePair, blob: Blob, point: tuple[float, float], *, moved: bool
    ) -> None:
        """The target seen moving at `point` in `pair`'s current frame, its pixels `blob`;
        `moved`: the patch before this one matched away from where it stood."""
        gray = pair.gray
        h, w = gray.shape[:2]
        x0, y0 = max(0, blob.x - GROW_PX), max(0, blob.y - GROW_PX)
        x1 = min(w, blob.x + blob.width + GROW_PX)
        y1 = min(h, blob.y + blob.height + GROW_PX)
        if min(x1 - x0, y1 - y0) < MIN_SIDE_PX:
            self.reset()
            return
        mask = np.zeros((y1 - y0, x1 - x0), np.uint8)
        top, left = blob.y - y0, blob.x - x0
        mask[top : top + blob.height, left : left + blob.width] = blob.mask
        self._mask = cv2.dilate(mask, _GROW_KERNEL)
        self._patch = gray[y0:y1, x0:x1].astype(np.float32)
        self._origin = (x0, y0)
        self._point = point
        self._box = (blob.x, blob.y, blob.x + blob.width, blob.y + blob.height)
        self._area_px = float(blob.area)
        self._t_s = pair.t_s
        self._H = np.eye(3)
        self._f_px = float(pair.step.K[0, 0])
        self._compensated = True  # every step since from the odometry
        self.moves = self.moves + 1 if moved and self._frame is not None else int(moved)
        self._frame = gray
        self.age_frames = 0
        self._shifts.clear()
        self._shifts.add(pair.t_s, 0.0, 0.0)

    def step(self, pair: FramePair) -> None:
        """The head's step to `pair`'s current frame (from the odometry where the pair is
        `compensated`; otherwise assumed still, and the patch's frame no longer maps by it)."""
        if self._frame is not None:
            self._H = pair.step.H @ self._H
            self._compensated = self._compensated and pair.compensated
            self.age_frames += 1

    def reference_pair(self, pair: FramePair) -> FramePair | None:
        """`pair`'s current frame against the patch's frame, by the head's steps since
        (`pair` itself where the patch was taken in its previous frame); None where a step
        since was not from the odometry: where the head went is not known."""
        if self._frame is None or pair.t_s <= self._t_s or not self._compensated:
            return None  # no patch; or the head's steps since are not all known
        if self._frame is pair.previous:
            return pair
        dt_s = pair.t_s - self._t_s
        K = pair.step.K
        zoom_rate_s = math.log(float(K[0, 0]) / self._f_px) / dt_s
        step = HeadStep(self._H, np.zeros(3), dt_s, K, zoom_rate_s)
        return FramePair(pair.gray, pair.t_s, self._frame, step, True)

    def match(
        self, pair: FramePair, background_px: tuple[float, float], error_px: float
    ) -> Held | None:
        """The target in `pair`'s current frame near where it stood, by its look: the patch's
        frame mapped by the head's steps and then moved by `background_px` (the background's
        own displacement against the patch's frame, where it was registered), `error_px` the
        bound on what is left of the poses' error. None where it does not match."""
        if self._frame is None:
            return None
        ph, pw = self._patch.shape
        scale = self._scale()  # newest pixels per pixel of the patch's frame
        radius = math.ceil(error_px / scale + SWAY_FRACTION * max(ph, pw))
        x0, y0 = self._origin[0] - radius, self._origin[1] - radius
        registered = np.array(
            [[1.0, 0.0, background_px[0]], [0.0, 1.0, background_px[1]], [0.0, 0.0, 1.0]]
        )
        H = registered @ self._H
        # the newest frame sampled on the patch frame's pixels about the patch
        to_newest = H @ np.array([[1.0, 0.0, x0], [0.0, 1.0, y0], [0.0, 0.0, 1.0]])
        size = (pw + 2 * radius, ph + 2 * radius)
        h, w = pair.gray.shape[:2]
        for cx in (0, size[0] - 1):
            for cy in (0, size[1] - 1):
                u, v = apply_homography(to_newest, cx, cy)
                if not (0 <= u <= w - 1 and 0 <= v <= h - 1):
                    return None  # the search reaches past the frame
        view = cv2.warpPerspective(
            pair.gray, to_newest, size, flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP
        ).astype(np.float32)
        scores = cv2.matchTemplate(view, self._patch, cv2.TM_CCOEFF_NORMED, mask=self._mask)
        scores = np.nan_to_num(scores, nan=-1.0, posinf=-1.0, neginf=-1.0)
        _, best, _, (mx, my) = cv2.minMaxLoc(scores)
        if best < MIN_CORRELATION:
            return None
        shift_x = mx - radius + _peak_offset(scores[my, max(mx - 1, 0) : mx + 2])
        shift_y = my - radius + _peak_offset(scores[max(my - 1, 0) : my + 2, mx])
        self._shifts.add(pair.t_s, shift_x, shift_y)
        du, dv = (scale * rate for rate in self._shifts.velocity() or (0.0, 0.0))
        u, v = apply_homography(H, self._point[0] + shift_x, self._point[1] + shift_y)
        left, top, right, bottom = self._box
        left, top = apply_homography(H, left + shift_x, top + shift_y)
        right, bottom = apply_homography(H, right + shift_x, bottom + shift_y)
        box = (left, top, right - left, bottom - top)
        area_px = self._area_px * scale * scale
        return Held(
            MoverRegion(u, v, du, dv, box, area_px, float(best)),
            scale * math.hypot(shift_x, shift_y),
        )

    def _scale(self) -> float:
        """The homography's local scale at the target's point: newest pixels per pixel of the
        patch's frame (the zoom's ratio of focal lengths, about)."""
        u, v = self._point
        u0, v0 = apply_homography(self._H, u, v)
        u1, v1 = apply_homography(self._H, u + 1.0, v)
        u2, v2 = apply_homography(self._H, u, v + 1.0)
        return math.sqrt(abs((u1 - u0) * (v2 - v0) - (u2 - u0) * (v1 - v0))) or 1.0


def _peak_offset(scores: np.ndarray) -> float:
    """The sub-pixel offset of a peak from the parabola through it and its two neighbours
    (`scores` the three; fewer, at the edge of the search: no offset)."""
    if len(scores) != 3:
        return 0.0
    left, peak, right = (float(x) for x in scores)
    curvature = left - 2.0 * peak + right
    return 0.0 if curvature >= 0.0 else 0.5 * (left - right) / curvature
