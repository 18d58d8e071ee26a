"""A digital head's movers, segmented in the fixed wide camera's frames.

A digital head's view moves, but the wide camera it is rendered from does not: background
subtraction holds there for good (it never relearns when the head turns), and it sees every
walker in the wide view, not only those in the view's fovea. So each wide frame is segmented as
it arrives (`SilhouetteModel`, with the rig's `[vision] background_*` settings, in colour where
the frame has it, so that cast shadows are told from walkers), each mover's appearance taken
from the wide frame's colour over its box; when the view rendered from that frame is processed,
the movers are mapped into the view at the pose it was rendered at. A wide pixel is undistorted
to the wide camera's ideal pixel and taken through the inverse of the view's homography
(`DigitalView.homography`); a box becomes its corners' box, a velocity goes through the map's
local Jacobian (the wide camera is still, so a wide velocity is already independent of the
head). Movers behind the view are left out; the others may lie outside the view's pixels, where
the head would see them if it turned.

The detection's own target comes first: the wide mover whose box holds the target's pixel
(nearest first). The view detector's own movers are not added: the wide camera's segmentation
reports every walker it sees, and a target of the view's detector that lies in no wide mover is
the moving view's residue, or a shadow the wide model left out; as a mover beside the wide ones
it would be a second, differently placed point of a walker they already report, and start a
second track on them.
"""

from __future__ import annotations

import dataclasses
from collections import OrderedDict
from collections.abc import Callable

import numpy as np

from gazed.config import VisionSection
from gazed.messages import HeadPose
from gazed.vision.appearance import colour_histogram
from gazed.vision.digital_view import DigitalView
from gazed.vision.ego_motion import HeadStep
from gazed.vision.frames import CapturedFrame, FrameError, checked_pixels, gray_frame
from gazed.vision.movers import MoverRegion
from gazed.vision.person_size import PersonSize
from gazed.vision.silhouettes import PointKind, SilhouetteModel
from gazed.vision.source import FrameSource, SourceStatus

KEPT_FRAMES = 64  # the wide frames whose movers are kept until their view is processed
JACOBIAN_STEP_PX = 0.5
MIN_DEPTH = 1e-6  # a wide ray with less depth along the view's axis is behind it


class WideMovers:
    """The movers of `view`'s wide camera, as its view sees them; see the module docstring."""

    def __init__(
        self,
        view: DigitalView,
        vision: VisionSection,
        point: PointKind,
        person: PersonSize | None = None,
    ) -> None:
        self.view = view
        self.point = point
        self.silhouettes = SilhouetteModel(
            level=vision.background_level,
            history_frames=vision.background_history_frames,
            threshold=vision.background_threshold,
            min_area_px=vision.background_min_area_px,
            learning_frames=vision.background_learning_frames,
            person=person,
            shadows=vision.background_shadows,
            ghosts=vision.background_ghosts,
        )
        self.frames = 0
        self._last_t_ns: int | None = None
        self._movers: OrderedDict[int, tuple[MoverRegion, ...]] = OrderedDict()

    def observe(self, frame: CapturedFrame) -> None:
        """Segment one wide frame (one that cannot be used is skipped: the view's own intake
        counts it)."""
        try:
            image = self.image(frame)
        except FrameError:
            return
        dt_s = 0.0 if self._last_t_ns is None else (frame.t_capture_ns - self._last_t_ns) * 1e-9
        self._last_t_ns = frame.t_capture_ns
        foreground = self.silhouettes.segment(image)
        movers: tuple[MoverRegion, ...] = ()
        if foreground is not None:
            still = HeadStep(np.eye(3), np.zeros(3), dt_s, self.view.wide.K)  # it never turns
            found = self.silhouettes.movers(
                foreground, self.point, still, frame.t_capture_ns * 1e-9
            )
            movers = tuple(self._described(m, frame) for m in found)
        self.frames += 1
        self._movers[frame.seq] = movers
        while len(self._movers) > KEPT_FRAMES:
            self._movers.popitem(last=False)

    def image(self, frame: CapturedFrame) -> np.ndarray:
        """What a wide frame's silhouettes are segmented in: its colour pixels, or grey where it
        has no colour (FrameError where it cannot be used)."""
        wide = self.view.wide
        if frame.encoding == "gray8":
            return gray_frame(frame, wide.width_px, wide.height_px)
        return checked_pixels(frame, wide.width_px, wide.height_px)  # not converted to grey

    def in_view(self, seq: int, pose: HeadPose) -> tuple[MoverRegion, ...] | None:
        """The movers of wide frame `seq` in the view's pixels at `pose`; None where that frame
        was not segmented."""
        movers = self._movers.get(seq)
        if movers is None:
            return None
        if not movers:
            return ()
        h = JACOBIAN_STEP_PX
        points = []
        for m in movers:
            x, y, w, bh = m.box
            points += [(m.u_px, m.v_px), (m.u_px + h, m.v_px), (m.u_px - h, m.v_px)]
            points += [(m.u_px, m.v_px + h), (m.u_px, m.v_px - h)]
            points += [(x, y), (x + w, y), (x, y + bh), (x + w, y + bh)]
        u, v, seen = self._to_view(np.array(points), pose)
        u, v, seen = (a.reshape(len(movers), 9) for a in (u, v, seen))
        mapped = []
        for i, m in enumerate(movers):
            if not seen[i].all():
                continue
            jacobian = np.array(
                [
                    [(u[i, 1] - u[i, 2]) / (2 * h), (u[i, 3] - u[i, 4]) / (2 * h)],
                    [(v[i, 1] - v[i, 2]) / (2 * h), (v[i, 3] - v[i, 4]) / (2 * h)],
                ]
            )
            du, dv = jacobian @ np.array([m.du_px_s, m.dv_px_s])
            x0, x1 = float(u[i, 5:].min()), float(u[i, 5:].max())
            y0, y1 = float(v[i, 5:].min()), float(v[i, 5:].max())
            mapped.append(
                dataclasses.replace(
                    m,
                    u_px=float(u[i, 0]),
                    v_px=float(v[i, 0]),
                    du_px_s=float(du),
                    dv_px_s=float(dv),
                    box=(x0, y0, x1 - x0, y1 - y0),
                )
            )
        return tuple(mapped)

    def tap(self, source: FrameSource) -> FrameSource:
        """`source` (the wide camera), each frame read from it segmented on the way."""
        return _Tap(source, self.observe)

    def _described(self, mover: MoverRegion, frame: CapturedFrame) -> MoverRegion:
        x, y, w, h = mover.box
        histogram = colour_histogram(frame.pixels, (x + w / 2.0, y + h / 2.0, w, h), frame.encoding)
        if histogram is None:
            return mover
        return dataclasses.replace(mover, appearance=tuple(histogram.tolist()))

    def _to_view(
        self, points: np.ndarray, pose: HeadPose
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Wide pixels (N, 2) -> view pixels u, v (N,) and whether each is in front of it."""
        ideal_u, ideal_v = self.view.wide.undistort(points[:, 0], points[:, 1])
        to_view = np.linalg.inv(self.view.homography(pose.pan_rad, pose.tilt_rad, pose.zoom))
        rays = to_view @ np.stack([ideal_u, ideal_v, np.ones(len(points))])
        seen = rays[2] > MIN_DEPTH
        depth = np.where(seen, rays[2], 1.0)
        return rays[0] / depth, rays[1] / depth, seen


def target_first(
    target_px: tuple[float, float] | None, wide: tuple[MoverRegion, ...]
) -> tuple[MoverRegion, ...]:
    """The wide movers with the target's own first: the one whose box holds the target's pixel
    (the nearest such). No target, or none holding it: the wide movers as they are."""
    if target_px is None:
        return wide
    u, v = target_px
    holding = [
        i
        for i, m in enumerate(wide)
        if m.box[0] <= u <= m.box[0] + m.box[2] and m.box[1] <= v <= m.box[1] + m.box[3]
    ]
    if not holding:
        return wide
    first = min(holding, key=lambda i: np.hypot(wide[i].u_px - u, wide[i].v_px - v))
    return (wide[first], *wide[:first], *wide[first + 1 :])


class _Tap(FrameSource):
    """A frame source whose frames are handed to `observe` as they are read."""

    def __init__(self, source: FrameSource, observe: Callable[[CapturedFrame], None]) -> None:
        self.source = source
        self.observe = observe
        self.description = source.description

    @property
    def is_connected(self) -> bool:
        return self.source.is_connected

    def connect(self) -> None:
        self.source.connect()

    def disconnect(self) -> None:
        self.source.disconnect()

    def read(self) -> CapturedFrame | None:
        frame = self.source.read()
        if frame is not None:
            self.observe(frame)
        return frame

    def status(self) -> SourceStatus:
        return self.source.status()

    def due_in_s(self) -> float | None:
        return self.source.due_in_s()
