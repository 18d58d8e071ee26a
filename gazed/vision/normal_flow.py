"""The `flow` detector: foveal normal flow with ego-rotation compensation (seed 000 §2).

In a small foveal window (the paper's ~6°), the motion constraint `E_t + ṙ·∇E = 0` gives at
each pixel the edge-normal component of the image motion,

    v = -E_t ∇E / |∇E|²                                   (seed 000 §2)

and the head's own rotation adds a known flow `ṙ_rot` (seed 004 eq. 11, `ego_motion`), whose
normal component is removed:

    v_ind = v - [ṙ_rot · v̂] v̂                              (seed 000 §2)

Background is where |v_ind| is within `noise_px` per frame; the rest is grouped into regions
(8-connected after a 3x3 closing, at least `min_area_px`), all assumed to be the one target
(seed 000 §2). The target's velocity is the least-squares fit of a single image velocity d to
the regions' normal-flow constraints `v̂·d = |v_ind|` (each weighted by |∇E|², i.e.
`∇E·d = -E_t`), its position the centroid of the pixels that this velocity explains.

The linearised constraint holds only for displacements of about a pixel per frame, while a
turning head moves the background many pixels per frame. So `E_t` is taken against the
previous frame sampled where the fovea was (shifted by the ego-rotation displacement of the
window's centre, `s`); the normal flow of that shifted pair plus `v̂·s` is the paper's `v`, and
the per-pixel ego flow is subtracted as above (`flow_constraints`). The target's own
displacement d is fitted the same way, Lucas-Kanade style: the previous frame is re-sampled at
`s + d` and the fit repeated, starting from three hypotheses (still in the world, still in the
image — the head pursuing it —, or moving as it did in the last frame) and keeping the one that
explains most pixels. When none explains `ACQUIRED_SCORE` of the region, the same fits on
images smoothed more (`COARSE_SIGMA_PX`, a wider linear range) give a fourth start. A fit
explaining less than `MIN_SCORE` is not reported.

The ego-rotation is only as good as the head pose at capture (an encoder step can be a
sizeable fraction of a pixel): on strong edges the residual then exceeds the noise, and a fit
can win that keeps its place in the world (|d| within the noise plus `EGO_ERROR` of the head's
displacement). That is background: its pixels are dropped and the rest fitted again; a region
with nothing else is not a target (a lone residual would otherwise be pursued as one).

The two poses are each off by the head's pose noise σ (`pose_noise_rad`), and a small rotation
error moves a small window alike: the background shifts by about √2 σ f, beyond the still limit
at a long focal length, where a slow target could not be told from it. So the fovea is first
registered on its surround (`_background`): the displacement most of the ring around it shares is
taken into the window's shift, and the target's displacement is fitted against the background
as imaged. Registered, a target slower than the noise shows nothing against the previous
frame; a fovea that shows nothing is looked at again against the frame `BASELINE_FRAMES` back
(`FramePair.older`), where such a target has moved several frames' worth. A surround that moves
together further than the poses' noise allows says the poses are wrong, not noisy (read at the
wrong instant while the head turns): the fovea's background moves with it, and the frame shows
nothing.

Besides the target, the window's other regions that move against the background clear of the
target (outside its box grown by half its size) are movers (`gazed.vision.movers`), each with
the velocity of its recent centroids (`RegionTracks`); the target's own comes first, with the
fitted velocity. The window is a fovea, not the frame: the movers are those it covers.

A target that stops shows nothing but the poses' residue on its own texture; the detector keeps
its look from the last frame it saw it move in and holds it where it stands (`still_target`):
first, before the motion is looked at, where the look has stayed put over the longer baseline,
and again where nothing moves in the fovea.

The window follows the target: it is centred on the predicted position while the target is
found, and returns to the principal point when it is lost. It spans the fovea at each frame's
focal length (a zoom lens's, at the frame's zoom).
"""

from __future__ import annotations

import functools
import math
from collections import deque
from dataclasses import dataclass

import cv2
import numpy as np

from gazed.geometry.camera import CameraModel
from gazed.vision.detector import BASELINE_FRAMES, DetectorOutput, FramePair
from gazed.vision.ego_motion import HeadStep
from gazed.vision.flow_constraints import (
    COARSE_SIGMA_PX,
    LINEAR_RANGE_PX,
    SMOOTHING_SIGMA_PX,
    FlowConstraints,
    FlowFit,
    FlowWindow,
    Fovea,
    window_offsets_px,
)
from gazed.vision.movers import MoverRegion, blobs, trimmed
from gazed.vision.region_tracks import RegionTracks
from gazed.vision.still_target import Held, StillTarget

MARGIN_PX = 6  # the window keeps this far from the image border
ACQUIRED_SCORE = 0.3  # a fit explaining less of the region than this tries the coarse scale
MIN_SCORE = 0.2  # ... and one explaining less than this is not reported
REFINE_ITERATIONS = 6  # further fits of the chosen hypothesis
CONVERGED_PX = 0.02  # stop refining when d changes by less than this (px per frame)
REFINE_RANGE_PX = 1.0  # constraints this far from a hypothesis pull it once it is chosen
VELOCITY_POINTS = 6  # the other movers' centroids their velocities are fitted to
EGO_ERROR = 0.05  # the fraction of the head's turn between frames the odometry can be off by
SURROUND = 3  # the background is registered on a window this many times the fovea's side
LATTICE_STEP = 4  # ... on every this-many-th pixel of each axis
REDUCTION = 2  # ... of the frames reduced this many times (the coarse scale loses nothing)
BACKGROUND_MIN_CONSTRAINTS = 50  # ... when it gives at least this many constraints
BACKGROUND_SCORE = 0.5  # ... and its displacement explains at least this share of them
_CLOSING_KERNEL = np.ones((3, 3), np.uint8)


@dataclass(frozen=True)
class Registration:
    """The background's own displacement about the fovea beyond the head's step (None: not
    registered), and whether the surround moved together further than the head poses' noise
    allows: the poses, not the world, are off (`NormalFlowDetector._background`)."""

    displacement: tuple[float, float] | None
    poses_off: bool = False


NOT_REGISTERED = Registration(None)


@functools.lru_cache(maxsize=4)
def _lattice(side: int, step: int) -> np.ndarray:
    """(side, side) bool: every `step`-th pixel of each axis."""
    lattice = np.zeros((side, side), bool)
    lattice[::step, ::step] = True
    lattice.flags.writeable = False  # shared by every window of that side
    return lattice


def _side_px(focal_px: float, fovea_rad: float) -> int:
    """Side of a square window spanning `fovea_rad` at the image centre: 2 f tan(fovea/2)."""
    return max(8, round(2.0 * focal_px * math.tan(fovea_rad / 2.0)))


class NormalFlowDetector:
    name = "flow"
    needs_energy = False

    def __init__(
        self,
        camera: CameraModel,
        *,
        fovea_rad: float,
        noise_px: float,
        min_gradient: float,
        min_area_px: int,
        pose_noise_rad: float = 0.0,
    ) -> None:
        self.camera = camera
        self.pose_noise_rad = pose_noise_rad
        self.fovea_rad = fovea_rad
        self.side = self._fovea_side_px(camera.focal_px)
        self.noise_px = noise_px
        self.min_gradient = min_gradient
        self.min_area_px = min_area_px
        self._offsets_px = window_offsets_px(self.side)
        self._track: tuple[float, float, np.ndarray] | None = None  # u, v, d (px/frame)
        self._box_px: tuple[float, float] | None = None  # the target box's width, height
        self._tracks = RegionTracks(VELOCITY_POINTS)
        self._still = StillTarget()
        # the frames reduced for the surround (`_reduced`), the newest last
        # (and the still target's patch's frame)
        self._reductions: deque[tuple[np.ndarray, np.ndarray]] = deque(maxlen=BASELINE_FRAMES + 2)

    def reset(self) -> None:
        self._track = None
        self._box_px = None
        self._tracks.reset()
        self._still.reset()

    def detect(self, pair: FramePair) -> DetectorOutput:
        if pair.previous is None:
            self.reset()
            return DetectorOutput.nothing()
        self._still.step(pair)
        self._size_fovea(pair.step.K)
        centre, fovea = self._place(pair.step, pair.gray.shape)
        registration = self._background(pair, fovea, centre)  # against the previous frame
        if registration.poses_off:
            # the surround moved together beyond what the head poses allow: the poses are off
            # (odometry stamped wrong), and whatever moves in the fovea may be the background;
            # the patch's chained steps went through them
            self._still.reset()
            return DetectorOutput.nothing(fovea.rect)
        background = registration.displacement
        held, still_px, borne_out = self._match_still(pair, fovea, centre, background)
        moved = None if held is None else held.moved_px > still_px
        if moved and not borne_out:
            moved = None  # a move seen through head poses the background did not bear out
        if moved is False and self._still.confirmed and self._still.age_frames >= BASELINE_FRAMES:
            # the target has stood where it stood over the longer baseline: what moves on it
            # is the poses' residue
            return self._held(held, fovea)
        track = self._track[2] if self._track is not None else None
        found = self._find(pair, fovea, centre, track, moved, background)
        if found is None and pair.older is not None and self.pose_noise_rad:
            # nothing moves against the registered background: a target slower than the
            # noise moves several frames' worth against the older frame, where the background
            # registers too (unregistered, the poses' error moves it as much)
            ratio = pair.older.step.dt_s / pair.step.dt_s
            older_track = track * ratio if track is not None else None
            older = self._background(pair.older, fovea, centre)
            if older.displacement is not None:
                found = self._find(
                    pair.older,
                    fovea,
                    centre,
                    older_track,
                    moved,
                    older.displacement,
                    per_frame=1.0 / ratio,
                )
        if found is None:
            if held is not None and self._still.confirmed:
                return self._held(held, fovea)  # nothing moves there; it looks as it did
            self.reset()
            return DetectorOutput.nothing(fovea.rect)
        return found

    def _match_still(
        self,
        pair: FramePair,
        fovea: Fovea,
        centre: tuple[float, float],
        previous: tuple[float, float] | None,
    ) -> tuple[Held | None, float, bool]:
        """The target matched by its look where the detector last saw it move
        (`still_target`; None: no patch, no match, or the head's steps since not all known);
        how far from there it may be and still count as standing: the noise, and the poses'
        error where the background could not be registered; and whether the head poses are
        borne out: exact (no pose noise), or the background registered between the two frames.
        `previous`: the background registered against the previous frame, which a patch taken
        there shares."""
        reference = self._still.reference_pair(pair)
        if reference is None:
            return None, self.noise_px, False
        background, error_px = (0.0, 0.0), 0.0
        registered = None
        if self.pose_noise_rad:
            if reference is pair:
                registered = previous
            else:
                registered = self._background(reference, fovea, centre).displacement
            if registered is None:
                focal_px = float(pair.step.K[0, 0])
                error_px = 3.0 * math.sqrt(2.0) * self.pose_noise_rad * focal_px
            else:
                background = registered
        held = self._still.match(reference, background, error_px)
        borne_out = not self.pose_noise_rad or registered is not None
        return held, self.noise_px + error_px, borne_out

    def _held(self, held: Held, fovea: Fovea) -> DetectorOutput:
        """The target held by its look (`still_target`): the fovea stays on it, still."""
        own = held.mover
        self._track = (own.u_px, own.v_px, np.zeros(2))
        self._tracks.reset()
        return DetectorOutput(
            found=True,
            u_px=own.u_px,
            v_px=own.v_px,
            du_px_s=own.du_px_s,
            dv_px_s=own.dv_px_s,
            area_px=own.area_px,
            confidence=own.confidence,
            window=fovea.rect,
            movers=(own,),
        )

    def _find(
        self,
        pair: FramePair,
        fovea: Fovea,
        centre: tuple[float, float],
        track: np.ndarray | None,
        moved: bool | None,
        background: tuple[float, float] | None,
        per_frame: float = 1.0,
    ) -> DetectorOutput | None:
        """The target in `fovea` against `pair`'s earlier frame (None: nothing moves there
        against the background). `moved`: whether the target's patch matched this frame away
        from where it stood (None: no patch, no match, or a move the head poses do not bear
        out; `still_target`). `background`: the pair's registration (`_background`; None: not
        registered). `per_frame`: the share of the pair's displacement that one frame interval
        makes (below 1 for `FramePair.older`); the track keeps a frame's."""
        window = FlowWindow(
            pair, fovea, self._offsets_px, self.min_gradient, track, SMOOTHING_SIGMA_PX
        )
        if background is not None:
            window.register(background)
        # seed 000 §2: background where the ego-compensated normal flow is within the noise
        v_ind = window.independent_flow()
        moving = window.valid & (np.abs(v_ind) > self.noise_px)
        region = self._regions(moving)
        if region is None:
            return None
        fit = self._fit_velocity(pair, window, region, track)
        still_px = self._still_px(pair.step, fovea)
        if math.hypot(*fit.d) <= still_px:
            # most of it keeps its place in the world: background the compensation missed
            # (odometry error); whatever moves is in the rest, if anything
            region = self._regions(region & ~self._explained(region, window, fit))
            if region is not None:
                fit = self._fit_velocity(pair, window, region, track)
            if region is None or math.hypot(*fit.d) <= still_px:
                return None
        # the target: moving against the background, and explained by the fitted velocity
        target = self._regions(moving & self._explained(region, window, fit))
        if target is None:
            return None
        # its centroid from the image moments: area m00, (m10, m01) / m00
        moments = cv2.moments(target.view(np.uint8), binaryImage=True)
        area = moments["m00"]
        u, v = fovea.x0 + moments["m10"] / area, fovea.y0 + moments["m01"] / area
        if fit.score < MIN_SCORE:
            # something moves there, but no single velocity explains it: look there again
            # next frame, with no trust in the velocity
            self._track = (u, v, np.zeros(2))
            return DetectorOutput.nothing(fovea.rect)
        self._track = (u, v, fit.d * per_frame)
        dt = pair.step.dt_s
        du, dv = float(fit.d[0] / dt), float(fit.d[1] / dt)
        box = trimmed(fovea.x0, fovea.y0, target)
        assert box is not None  # the target holds pixels: its area is at least min_area_px
        own = MoverRegion(u, v, du, dv, box.box_at(1), area, fit.score)
        self._box_px = own.box[2], own.box[3]
        if moved is not False:  # a look that stays put keeps its patch, which ages
            self._still.remember(pair, box, (u, v), moved=moved is True)
        if per_frame != 1.0:  # the other movers' tracks step frame by frame
            self._tracks.reset()
            movers: tuple[MoverRegion, ...] = (own,)
        else:
            movers = self._movers(pair, fovea, moving & ~target, own)
        return DetectorOutput(
            found=True,
            u_px=u,
            v_px=v,
            du_px_s=du,
            dv_px_s=dv,
            area_px=area,
            confidence=fit.score,
            window=fovea.rect,
            movers=movers,
        )

    def _movers(
        self, pair: FramePair, fovea: Fovea, rest: np.ndarray, own: MoverRegion
    ) -> tuple[MoverRegion, ...]:
        """The target's own mover, then the other regions of the window that move against the
        background clear of the target: outside its box grown by half its size on every side
        (nearer, they are parts of the target its velocity does not explain), each with the
        velocity of its recent centroids."""
        x, y, w, h = own.box
        top, left = max(0, round(y - h / 2) - fovea.y0), max(0, round(x - w / 2) - fovea.x0)
        rest[top : round(y + 1.5 * h) - fovea.y0, left : round(x + 1.5 * w) - fovea.x0] = False
        if not rest.any():
            self._tracks.reset()
            return (own,)
        closed = cv2.morphologyEx(rest.view(np.uint8), cv2.MORPH_CLOSE, _CLOSING_KERNEL)
        others = [blob for blob, _ in blobs(closed, self.min_area_px, split=False)]
        if not others:
            self._tracks.reset()
            return (own,)
        centroids = [(own.u_px, own.v_px)]
        for blob in others:
            cu, cv = blob.centroid()
            centroids.append((fovea.x0 + cu, fovea.y0 + cv))
        boxes = [own.box] + [
            (fovea.x0 + b.x, fovea.y0 + b.y, float(b.width), float(b.height)) for b in others
        ]
        radii = [0.5 * max(b[2], b[3]) for b in boxes]
        areas = [own.area_px] + [float(blob.area) for blob in others]
        velocities = self._tracks.update(pair.step, centroids, radii, areas, pair.t_s)
        movers = [own]
        total = own.area_px + sum(blob.area for blob in others)
        for blob, (u, v), velocity, box in zip(
            others, centroids[1:], velocities[1:], boxes[1:], strict=True
        ):
            area = float(blob.area)
            movers.append(MoverRegion.tracked(u, v, velocity, box, area, area / total))
        return tuple(movers)

    @staticmethod
    def _explained(region: np.ndarray, window: FlowWindow, fit: FlowFit) -> np.ndarray:
        """The pixels of the region whose constraints the fit explains."""
        explained = np.zeros_like(region)
        explained[region & window.valid] = fit.inliers
        return explained

    def _background(
        self, pair: FramePair, fovea: Fovea, centre: tuple[float, float]
    ) -> Registration:
        """The background's own displacement about `fovea` beyond the head's step. The head poses
        the ego-rotation is taken from are each off by their noise, and a small rotation error moves
        the whole surround alike. The displacement b that most of the constraints of the ring
        between the fovea and a window `SURROUND` times its side share (away from the predicted
        target, on a lattice, at the coarse scale whose linear range spans a misregistration of a
        few pixels) is the background's own, and the fovea takes it into its shift
        (`FlowWindow.register`). Only a fit that explains most of its constraints, and within the
        still limit plus three standard deviations of the poses' misregistration (√2 σ f, σ the
        head's pose noise), is taken: otherwise the window stays as the odometry places it. Where
        most of the surround moves together beyond that bound, it is not the poses' noise but poses
        that are wrong (odometry stamped off the frames' exposures while the head turns): the
        registration says so (`poses_off`), and the fovea, whose own background moves with the
        surround, shows nothing that can be trusted. A head with no pose noise (the digital head,
        its view rendered at the pose it reports) has nothing to register.

        The surround is seen on the frames reduced `REDUCTION` times: smoothed at the coarse
        scale, a full-resolution image holds nothing at the reduced one's Nyquist frequency, so
        the constraints are the same at a fraction of the cost."""
        if self.pose_noise_rad == 0.0:
            return NOT_REGISTERED
        r = REDUCTION
        reduced = FramePair(
            self._reduced(pair.gray),
            pair.t_s,
            self._reduced(pair.previous),
            pair.step.reduced(r),
            True,
        )
        h, w = reduced.gray.shape[:2]
        margin = MARGIN_PX // r
        side = min(SURROUND * fovea.side // r, w - 2 * margin, h - 2 * margin)
        cu, cv = ((c - (r - 1) / 2.0) / r for c in centre)  # the reduced pixel of the centre
        x0 = min(max(round(cu - (side - 1) / 2.0), margin), w - margin - side)
        y0 = min(max(round(cv - (side - 1) / 2.0), margin), h - margin - side)
        scale = COARSE_SIGMA_PX / SMOOTHING_SIGMA_PX  # the coarse scale's, in full pixels
        surround = FlowWindow(
            reduced,
            Fovea(x0, y0, side),
            window_offsets_px(side),
            self.min_gradient * r / scale,  # a reduced pixel's gradient is r full pixels'
            None,
            COARSE_SIGMA_PX / r,
        )
        pixels = surround.valid & _lattice(side, LATTICE_STEP // r)

        def clear(left: float, top: float, right: float, bottom: float) -> None:
            """Leave out the full-resolution box (left, top)-(right, bottom), reduced."""
            pixels[
                max(0, math.floor(top / r) - y0) : max(0, math.ceil(bottom / r) - y0),
                max(0, math.floor(left / r) - x0) : max(0, math.ceil(right / r) - x0),
            ] = False

        # where the target is looked for: the ring about it is background
        clear(fovea.x0, fovea.y0, fovea.x0 + fovea.side, fovea.y0 + fovea.side)
        if self._track is not None and self._box_px is not None:
            bw, bh = self._box_px  # the target's box grown by half its size on every side
            clear(centre[0] - bw, centre[1] - bh, centre[0] + bw, centre[1] + bh)
        if np.count_nonzero(pixels) < BACKGROUND_MIN_CONSTRAINTS:
            return NOT_REGISTERED
        constraints = surround.constraints(pixels)
        noise = self.noise_px / r
        # wide fits at the coarse scale's linear range: from no displacement, and from the
        # shift the surround's phase correlation finds, however far (poses that are wrong, not
        # noisy, misregister it beyond the linear range)
        starts = [(0.0, 0.0)]
        for start in ((0.0, 0.0), _shared_shift(surround)):
            wide = constraints.fit(np.array([start]), LINEAR_RANGE_PX * scale / r, noise * scale)
            wide = _refined(constraints, wide, REFINE_RANGE_PX * scale / r, noise * scale)
            starts.append(tuple(wide.d))
        # the background is the displacement most constraints share, not the weighted mean: a
        # strongly textured target in the surround pulls the least squares (weighted by |∇E|²)
        # towards itself; so from no displacement and from the wide fits, each refined on the
        # constraints within the pixel noise of it, the one that explains the most
        fit = constraints.fit(np.array(starts), noise, noise)
        fit = _refined(constraints, fit, noise, noise)
        background = fit.d * r
        misregistration_px = math.sqrt(2.0) * self.pose_noise_rad * float(pair.step.K[0, 0])
        bound_px = self._still_px(pair.step, fovea) + 3.0 * misregistration_px
        if fit.score < BACKGROUND_SCORE:
            return NOT_REGISTERED
        if math.hypot(*background) > bound_px:
            return Registration(None, poses_off=True)
        return Registration((float(background[0]), float(background[1])))

    def _reduced(self, image: np.ndarray) -> np.ndarray:
        """`image` reduced `REDUCTION` times (block means), kept for the frames that follow."""
        for source, reduced in self._reductions:
            if source is image:
                return reduced
        h, w = image.shape[:2]
        reduced = cv2.resize(image, (w // REDUCTION, h // REDUCTION), interpolation=cv2.INTER_AREA)
        self._reductions.append((image, reduced))
        return reduced

    def _still_px(self, step: HeadStep, fovea: Fovea) -> float:
        """The largest displacement (px per frame) of a region that still counts as keeping its
        place in the world: the noise, plus the error of the ego-rotation displacement it was
        compensated by, a fraction EGO_ERROR of that displacement (head pose at capture)."""
        cu, cv = fovea.centre
        tu, tv = step.transport(cu, cv)
        return self.noise_px + EGO_ERROR * math.hypot(tu - cu, tv - cv)

    def _fovea_side_px(self, focal_px: float) -> int:
        return min(
            _side_px(focal_px, self.fovea_rad),
            self.camera.width_px - 2 * MARGIN_PX,
            self.camera.height_px - 2 * MARGIN_PX,
        )

    def _size_fovea(self, K: np.ndarray) -> None:
        """The window spans the fovea at the frame's focal length (a zoom lens changes it)."""
        side = self._fovea_side_px(0.5 * float(K[0, 0] + K[1, 1]))
        if side != self.side:
            self.side = side
            self._offsets_px = window_offsets_px(side)

    def _place(self, step: HeadStep, shape: tuple[int, ...]) -> tuple[tuple[float, float], Fovea]:
        """Centre the fovea on the predicted target, or on the frame's principal point: that
        centre, and the fovea (kept inside the image)."""
        if self._track is not None:
            u, v, d = self._track
            u, v = step.transport(u, v)
            cu, cv = u + d[0], v + d[1]
        else:
            cu, cv = step.K[0, 2], step.K[1, 2]
        h, w = shape[:2]
        x0 = round(cu - (self.side - 1) / 2.0)
        y0 = round(cv - (self.side - 1) / 2.0)
        x0 = min(max(x0, MARGIN_PX), w - MARGIN_PX - self.side)
        y0 = min(max(y0, MARGIN_PX), h - MARGIN_PX - self.side)
        return (cu, cv), Fovea(x0, y0, self.side)

    def _regions(self, mask: np.ndarray) -> np.ndarray | None:
        """Seed 000 §2: group foreground pixels into regions; their union, or None."""
        closed = cv2.morphologyEx(mask.view(np.uint8), cv2.MORPH_CLOSE, _CLOSING_KERNEL)
        count, labels = cv2.connectedComponents(closed, connectivity=8)
        # each region's area: its label's pixel count (cheaper than OpenCV's full statistics)
        keep = np.bincount(labels.ravel(), minlength=count) >= self.min_area_px
        keep[0] = False  # the background label
        if not keep.any():
            return None
        return keep.take(labels)

    def _fit_velocity(
        self,
        pair: FramePair,
        window: FlowWindow,
        region: np.ndarray,
        track: np.ndarray | None,
    ) -> FlowFit:
        """Least-squares image velocity of the region from its normal-flow constraints: fits
        from each hypothesis; if none explains the region, the same at a coarser scale (a
        wider linear range) gives another start; then the best one refined."""
        constraints = window.constraints(region & window.valid)
        best = constraints.fit(window.hypotheses, LINEAR_RANGE_PX, self.noise_px)
        if best.score < ACQUIRED_SCORE:
            scale = COARSE_SIGMA_PX / SMOOTHING_SIGMA_PX
            coarse = FlowWindow(
                pair,
                window.fovea,
                self._offsets_px,
                self.min_gradient / scale,
                track,
                COARSE_SIGMA_PX,
            )
            if window.background != (0.0, 0.0):
                coarse.register(window.background)
            wide = coarse.constraints(region & coarse.valid)
            start = wide.fit(coarse.hypotheses, LINEAR_RANGE_PX * scale, self.noise_px * scale)
            start = _refined(wide, start, REFINE_RANGE_PX * scale, self.noise_px * scale)
            candidate = constraints.fit(start.d[None], LINEAR_RANGE_PX, self.noise_px)
            if candidate.score > best.score:
                best = candidate
        return _refined(constraints, best, REFINE_RANGE_PX, self.noise_px)


@functools.lru_cache(maxsize=4)
def _hanning(side: int) -> np.ndarray:
    window = cv2.createHanningWindow((side, side), cv2.CV_32F)
    window.flags.writeable = False  # shared by every window of that side
    return window


def _shared_shift(window: FlowWindow) -> tuple[float, float]:
    """The displacement (the window's pixels) by which its content moved from the previous
    frame as the odometry places it: the phase correlation of the two, whose peak is the shift
    most of the window shares."""
    previous = window.previous_at((0.0, 0.0))
    (du, dv), _ = cv2.phaseCorrelate(previous, window.current, _hanning(window.fovea.side))
    return float(du), float(dv)


def _refined(
    constraints: FlowConstraints, fit: FlowFit, tolerance_px: float, noise_px: float
) -> FlowFit:
    """`fit` refined on the constraints within `tolerance_px` of it, step by step, until it
    moves by less than `CONVERGED_PX` (or for at most `REFINE_ITERATIONS` steps)."""
    for _ in range(REFINE_ITERATIONS):
        refined = constraints.fit(fit.d[None], tolerance_px, noise_px)
        moved = math.hypot(*(refined.d - fit.d))
        fit = refined
        if moved < CONVERGED_PX:
            break
    return fit
