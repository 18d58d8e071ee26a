"""The image motion the head's own rotation induces: angular velocity, rotational flow, warp.

A camera that only rotates moves every static scene point the same way whatever its depth
(seed 004 §5, eq. 11; seed 000 §2): the flow is known from the joint angles and rates alone.

Frames (see `gazed.geometry.kinematics`): `C = camera_to_base(pan, tilt)` maps directions in the
OpenCV camera frame (x right, y down, z forward) to the head base frame. A static direction `d`
is seen at pixel `x ≃ K C^T d`, so between a capture at pose 1 and one at pose 2

    x2 ≃ K C2^T C1 K^-1 x1                       (the pure-rotation warp K R K^-1)

and, for a rotating camera, `dP/dt = -ω × P` in camera coordinates with `[ω]x = C^T dC/dt`;
with normalised coordinates x = X/Z, y = Y/Z this gives the rotational part of seed 004 eq. 11,

    dx/dt = x y ωx - (1 + x²) ωy + y ωz
    dy/dt = (1 + y²) ωx - x y ωy - x ωz          (scaled by fx, fy to pixels per second).

A zoom lens changes `K` between the two captures (each frame's camera is the lens at the zoom
of its pose, `ZoomLens.at_pose`): the warp is then K2 C2^T C1 K1^-1, and a focal length f
changing at the relative rate s = d(ln f)/dt adds the flow s (u - cx, v - cy) of an image
growing about its principal point. Across a window that flow is not one shift: a window
compared with the previous frame samples that frame at its scale f1 / f2 (`HeadStep.scale`),
which leaves only the rotation's small residual to the linearised correction.

Lens distortion is not modelled here: the flow and the warp are those of the ideal pinhole `K`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np

from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.zoom import ZoomLens
from gazed.messages import HeadPose


def camera_angular_velocity(
    kinematics: HeadKinematics,
    pan_rad: float,
    tilt_rad: float,
    pan_rate_rad_s: float,
    tilt_rate_rad_s: float,
) -> np.ndarray:
    """ω (rad/s, shape (3,)) of the camera in its own OpenCV frame, `[ω]x = C^T dC/dt`.

    pan-tilt (R = Ry(p) Rx(-t)):  ω = (ṫ, ṗ cos t, -ṗ sin t)
    tilt-pan (R = Rx(-t) Ry(p)):  ω = (ṫ cos p, ṗ, ṫ sin p)
    Derived from R^T dR/dt = ṗ [a_p]x + ṫ [a_t]x and the y flip `F`, `F [w]x F = -[F w]x`.
    """
    p, t, dp, dt = pan_rad, tilt_rad, pan_rate_rad_s, tilt_rate_rad_s
    if kinematics.kinematics == "pan-tilt":
        return np.array([dt, dp * math.cos(t), -dp * math.sin(t)])
    return np.array([dt * math.cos(p), dp, dt * math.sin(p)])


def rotational_flow(
    K: np.ndarray, omega: np.ndarray, u_px: np.ndarray, v_px: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Image velocity (px/s) of static scene points at pixels (u, v) for camera rotation ω.

    Seed 004 eq. 11, rotational part, in normalised coordinates, scaled by the focal lengths.
    """
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    x = (np.asarray(u_px, dtype=np.float64) - cx) / fx
    y = (np.asarray(v_px, dtype=np.float64) - cy) / fy
    wx, wy, wz = (float(w) for w in omega)
    dx = x * y * wx - (1.0 + x * x) * wy + y * wz  # eq. 11a, rotational part
    dy = (1.0 + y * y) * wx - x * y * wy - x * wz  # eq. 11b, rotational part
    return fx * dx, fy * dy


def rotation_homography(
    camera: CameraModel,
    kinematics: HeadKinematics,
    head_from: HeadPose,
    head_to: HeadPose,
    camera_to: CameraModel | None = None,
) -> np.ndarray:
    """H = K_to C_to^T C_from K_from^-1 (3x3, H[2,2] = 1): a static point's pixel at `head_from`
    (seen by `camera`) -> its pixel at `head_to` (seen by `camera_to`, the same camera if not
    given). `cv2.warpPerspective(previous, H, size)` lays the previous frame over the current
    one (seed 004 §5, "compensation of image itself")."""
    c_from = kinematics.camera_to_base(head_from.pan_rad, head_from.tilt_rad)
    c_to = kinematics.camera_to_base(head_to.pan_rad, head_to.tilt_rad)
    K_to = camera.K if camera_to is None else camera_to.K
    H = K_to @ c_to.T @ c_from @ camera.K_inv
    return H / H[2, 2]


def apply_homography(H: np.ndarray, u_px: float, v_px: float) -> tuple[float, float]:
    """Where pixel (u, v) goes under H (in floats: a 3x3 product is not worth NumPy's calls)."""
    (h00, h01, h02), (h10, h11, h12), (h20, h21, h22) = H.tolist()
    w = h20 * u_px + h21 * v_px + h22
    return (h00 * u_px + h01 * v_px + h02) / w, (h10 * u_px + h11 * v_px + h12) / w


@dataclass(frozen=True)
class HeadStep:
    """The head's rotation between two captures `dt_s` apart.

    `H` maps previous pixels to current ones; `omega` is the mean angular velocity over the
    interval (from the two poses, so it stays consistent with `H` when the head accelerates and
    when the device reports no rates), evaluated at the mid-interval pose. `K` is the current
    frame's camera, `zoom_rate_s` the relative rate d(ln f)/dt of its focal length over the
    interval (0 for a fixed lens).
    """

    H: np.ndarray
    omega: np.ndarray
    dt_s: float
    K: np.ndarray
    zoom_rate_s: float = 0.0

    def flow(self, u_px: np.ndarray, v_px: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Flow (px/s) of static points at pixels of the current frame: the rotational flow
        (seed 004 eq. 11) and the zoom's growth about the principal point."""
        du, dv = rotational_flow(self.K, self.omega, u_px, v_px)
        if self.zoom_rate_s == 0.0:
            return du, dv
        s = self.zoom_rate_s
        return du + s * (np.asarray(u_px) - self.K[0, 2]), dv + s * (
            np.asarray(v_px) - self.K[1, 2]
        )

    def displacement(
        self, u_px: float | np.ndarray, v_px: float | np.ndarray
    ) -> tuple[float | np.ndarray, float | np.ndarray]:
        """How far (px) static points now at pixels (u, v) moved over the interval: (u, v)
        less their pixel in the previous frame, H⁻¹ (u, v) (exact for a pure rotation). u and v
        broadcast: a window's row of u and column of v give its whole grid."""
        (g00, g01, g02), (g10, g11, g12), (g20, g21, g22) = self.H_inverse.tolist()
        # each row's u term and constant first: a row of u and a column of v then meet in one
        # broadcast sum per row of H⁻¹
        w = (g20 * u_px + g22) + g21 * v_px
        return (
            u_px - ((g00 * u_px + g02) + g01 * v_px) / w,
            v_px - ((g10 * u_px + g12) + g11 * v_px) / w,
        )

    @property
    def scale(self) -> float:
        """The previous frame's focal length over the current one's, f1 / f2: a zooming lens
        shows the scene at this scale in the previous frame (1 for a fixed lens)."""
        return 1.0 if self.zoom_rate_s == 0.0 else math.exp(-self.zoom_rate_s * self.dt_s)

    def sampled_less_displacement(
        self,
        shift_px: tuple[float, float],
        centre_px: tuple[float, float],
        origin_px: tuple[int, int],
        offsets_px: np.ndarray,
    ) -> np.ndarray:
        """H⁻¹x - P(x) (px, the shape of `offsets_px`): where the static point now at pixel x
        was in the previous frame, less where a window sampling the previous frame looks for
        it. x = `origin_px` + `offsets_px` (offsets (..., 2) float64, u then v; a window's
        grid); the window, centred on c = `centre_px`, samples the previous frame shifted by
        s = `shift_px` and at the lens's `scale` k about its centre, P(x) = c - s + k (x - c).
        For a fixed lens (k = 1) this is s - w, w = x - H⁻¹x the displacement of static points.
        One perspective transform of the offsets, with the origin and the constant folded into
        the matrix T(a) H⁻¹ T(origin), a = s - origin + (1 - k)(origin - c), less k times the
        offsets."""
        (g00, g01, g02), (g10, g11, g12), (g20, g21, g22) = self.H_inverse.tolist()
        x0, y0 = origin_px
        k = self.scale
        # H⁻¹ T(origin): the origin moves into the last column; T(a) adds a times the last row
        # to the first two
        c0 = g00 * x0 + g01 * y0 + g02
        c1 = g10 * x0 + g11 * y0 + g12
        c2 = g20 * x0 + g21 * y0 + g22
        a = shift_px[0] - x0 + (1.0 - k) * (x0 - centre_px[0])
        b = shift_px[1] - y0 + (1.0 - k) * (y0 - centre_px[1])
        folded = np.array(
            [
                [g00 + a * g20, g01 + a * g21, c0 + a * c2],
                [g10 + b * g20, g11 + b * g21, c1 + b * c2],
                [g20, g21, c2],
            ]
        )
        moved = cv2.perspectiveTransform(offsets_px, folded)
        moved -= offsets_px if k == 1.0 else k * offsets_px
        return moved

    def reduced(self, factor: int) -> HeadStep:
        """The same step on both frames reduced `factor` times, each reduced pixel the mean of a
        factor x factor block: full-resolution pixel x is reduced pixel A x = (x - (factor - 1)
        / 2) / factor, so H becomes A H A⁻¹ and K becomes A K."""
        offset = (factor - 1) / 2.0
        A = np.array([[1.0, 0.0, -offset], [0.0, 1.0, -offset], [0.0, 0.0, factor]]) / factor
        A_inverse = np.array([[factor, 0.0, offset], [0.0, factor, offset], [0.0, 0.0, 1.0]])
        H = A @ self.H @ A_inverse
        return HeadStep(H, self.omega, self.dt_s, A @ self.K, self.zoom_rate_s)

    @cached_property
    def H_inverse(self) -> np.ndarray:
        """Current pixels -> previous ones."""
        return cv2.invert(self.H)[1]  # one 3x3: cheaper than np.linalg.inv's call

    def transport(self, u_px: float, v_px: float) -> tuple[float, float]:
        """Where a static point at (u, v) in the previous frame appears in the current one."""
        return apply_homography(self.H, u_px, v_px)


class EgoMotion:
    """Rotational ego-motion of one camera on one head (the camera's K, the head's R); with a
    zoom `lens`, each pose's K is the lens's at the pose's zoom."""

    def __init__(
        self, camera: CameraModel, kinematics: HeadKinematics, lens: ZoomLens | None = None
    ) -> None:
        self.camera = camera
        self.kinematics = kinematics
        self.lens = ZoomLens.fixed(camera) if lens is None else lens

    def angular_velocity(self, head: HeadPose) -> np.ndarray:
        """ω of the camera (OpenCV frame, rad/s) at a pose with its rates."""
        return camera_angular_velocity(
            self.kinematics, head.pan_rad, head.tilt_rad, head.pan_rate_rad_s, head.tilt_rate_rad_s
        )

    def flow(
        self, head: HeadPose, u_px: np.ndarray, v_px: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Rotational flow (px/s) at pixels (u, v) for the pose and rates in `head`."""
        K = self.lens.at_pose(head).K
        return rotational_flow(K, self.angular_velocity(head), u_px, v_px)

    def homography(self, head_from: HeadPose, head_to: HeadPose) -> np.ndarray:
        camera_from, camera_to = self.lens.at_pose(head_from), self.lens.at_pose(head_to)
        return rotation_homography(camera_from, self.kinematics, head_from, head_to, camera_to)

    def step(self, head_from: HeadPose, head_to: HeadPose, dt_s: float) -> HeadStep:
        """The rotation between two captures: warp, and mean angular velocity over the interval."""
        if dt_s <= 0:
            raise ValueError(f"captures must be in time order (dt = {dt_s} s)")
        # ω at the mid-interval pose with the mean rates (straight from the angles: no HeadPose
        # to validate, once per frame)
        omega = camera_angular_velocity(
            self.kinematics,
            0.5 * (head_from.pan_rad + head_to.pan_rad),
            0.5 * (head_from.tilt_rad + head_to.tilt_rad),
            (head_to.pan_rad - head_from.pan_rad) / dt_s,
            (head_to.tilt_rad - head_from.tilt_rad) / dt_s,
        )
        camera_from, camera_to = self.lens.at_pose(head_from), self.lens.at_pose(head_to)
        H = rotation_homography(camera_from, self.kinematics, head_from, head_to, camera_to)
        zoom_rate_s = 0.0
        if camera_to is not camera_from:
            zoom_rate_s = math.log(camera_to.focal_px / camera_from.focal_px) / dt_s
        return HeadStep(H, omega, dt_s, camera_to.K, zoom_rate_s)

    def still_step(self, dt_s: float, head: HeadPose | None = None) -> HeadStep:
        """A step for a head known (or assumed) to be still: identity warp, no flow (the
        camera at `head`'s zoom, the rig's without it)."""
        return HeadStep(np.eye(3), np.zeros(3), dt_s, self.lens.at_pose(head).K)
