"""Image measurements <-> ground plane for a calibrated rig (seed 000 §3, DESIGN §4).

A target seen at pixel (u, v) with the head at (pan, tilt) lies on the base-frame ray
d = R(pan, tilt) · flip_y · K^-1 (u, v, 1) (kinematics.py), which meets the ground at
X ≃ M d (homography.py; no need to pass through the frontal plane, so any ray below the horizon
works), then moves by the height correction (height.py). The way back centres a ground point:
d ≃ M^-1 (X, Y, 1) and (pan, tilt) = angles_from_direction(d).

Velocities come by the chain rule through the analytic Jacobians: the ground velocity of a
target whose pixel moves at (u', v') while the head turns at (pan', tilt') is
J_angles (pan', tilt') + J_pixel (u', v'), where (u', v') is the total rate of change of the
target's pixel as a tracker sees it across frames (ego-motion included). Covariances are
propagated to first order from independent angle, angle-rate, pixel and pixel-rate noise.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from gazed.config import HeadSection, Rig
from gazed.geometry.camera import CameraModel
from gazed.geometry.height import HeightCorrection
from gazed.geometry.homography import GroundHomography
from gazed.geometry.kinematics import FLIP_Y, HeadKinematics

# Forward-difference steps for the derivative of the velocity by the position inputs:
# (pan, tilt, u, v) move by at most these.
ANGLE_STEP_RAD = 1e-8
PIXEL_STEP_PX = 1e-5
INPUT_STEPS = np.array([ANGLE_STEP_RAD, ANGLE_STEP_RAD, PIXEL_STEP_PX, PIXEL_STEP_PX])


class MissingCalibrationError(ValueError):
    """The rig has no [calibration] homography."""


@dataclass(frozen=True)
class MeasurementNoise:
    """Standard deviations of an image measurement's inputs, independent: the same per axis,
    but for `extent_px`, the std on each image axis (u, v) that a region's extent adds to its
    point (`for_region`)."""

    angle_rad: float
    angle_rate_rad_s: float
    pixel_px: float
    pixel_rate_px_s: float
    extent_px: tuple[float, float] = (0.0, 0.0)

    @classmethod
    def from_head(
        cls, head: HeadSection, pixel_px: float, pixel_rate_px_s: float
    ) -> MeasurementNoise:
        """Angle noise from the rig's [head]; pixel noise is the detector's."""
        return cls(head.angle_noise_rad, head.angle_rate_noise_rad_s, pixel_px, pixel_rate_px_s)

    def for_region(
        self, width_px: float, height_px: float, fraction: tuple[float, float]
    ) -> MeasurementNoise:
        """The noise of the point of a region (a mover's mask) `width_px` by `height_px`: where
        the region's extent is uncertain by a fraction of itself, so is its point, by
        `fraction` (u, v) of the extent on each axis."""
        return replace(self, extent_px=(fraction[0] * width_px, fraction[1] * height_px))

    def pixel_variances(self) -> np.ndarray:
        """(2,): the point's variance along u and along v."""
        return self.pixel_px**2 + np.square(self.extent_px)

    def variances(self) -> np.ndarray:
        """(8,), order (pan, tilt, u, v, pan_rate, tilt_rate, u_rate, v_rate)."""
        angles = np.square([self.angle_rad] * 2)
        rates = np.square([self.angle_rate_rad_s] * 2 + [self.pixel_rate_px_s] * 2)
        return np.concatenate([angles, self.pixel_variances(), rates])


@dataclass(frozen=True)
class GazeSample:
    """One image measurement: head angles and rates at capture time (odometry interpolated),
    the target's pixel and the pixel's rate of change."""

    pan_rad: float
    tilt_rad: float
    u_px: float
    v_px: float
    pan_rate_rad_s: float = 0.0
    tilt_rate_rad_s: float = 0.0
    u_rate_px_s: float = 0.0
    v_rate_px_s: float = 0.0


@dataclass(frozen=True, eq=False)
class GroundMeasurement:
    """Ground position (2,), velocity (2,) and their covariance (4x4, order X, Y, X', Y')."""

    position_m: np.ndarray
    velocity_m_s: np.ndarray
    covariance: np.ndarray


@dataclass(frozen=True, eq=False)
class GroundGeometry:
    """Camera, head, homography and optional height correction of one rig."""

    camera: CameraModel
    head: HeadKinematics
    homography: GroundHomography
    height: HeightCorrection | None = None

    @classmethod
    def from_rig(cls, rig: Rig) -> GroundGeometry:
        """From [camera], [head] and [calibration]; raises MissingCalibrationError without a
        homography."""
        calibration = rig.calibration
        homography = GroundHomography.from_section(calibration)
        if homography is None:
            raise MissingCalibrationError(
                f"rig '{rig.name}': [calibration] homography is missing: calibrate with "
                "`gazed calibrate points FILE --write RIG` (or `lines`)"
            )
        return cls(
            CameraModel.from_section(rig.camera),
            HeadKinematics.from_section(rig.head),
            homography,
            HeightCorrection.from_section(calibration),
        )

    def with_camera(self, camera: CameraModel) -> GroundGeometry:
        """The same rig seen through `camera` (the lens at another zoom)."""
        return self if camera is self.camera else replace(self, camera=camera)

    def ray(
        self,
        pan_rad: float,
        tilt_rad: float,
        u_px: float | np.ndarray | None = None,
        v_px: float | np.ndarray | None = None,
    ) -> np.ndarray:
        """Base-frame ray(s) (..., 3) through pixel(s) (u, v); the optical axis when omitted."""
        if u_px is None or v_px is None:
            return self.head.gaze(pan_rad, tilt_rad)
        return self.camera.ray(u_px, v_px) @ self.head.camera_to_base(pan_rad, tilt_rad).T

    def ground_from_gaze(
        self,
        pan_rad: float,
        tilt_rad: float,
        u_px: float | np.ndarray | None = None,
        v_px: float | np.ndarray | None = None,
    ) -> np.ndarray:
        """Ground position(s) (..., 2) of the target at pixel(s) (u, v) (the image centre when
        omitted) with the head at (pan, tilt), height-corrected. Raises HorizonError for a ray
        at or above the horizon."""
        hit = self.homography.ground_from_direction(self.ray(pan_rad, tilt_rad, u_px, v_px))
        return hit if self.height is None else self.height.target_from_hit(hit)

    def ground_jacobian(
        self, pan_rad: float, tilt_rad: float, u_px: float, v_px: float
    ) -> np.ndarray:
        """d(X, Y)/d(pan, tilt, u, v) of `ground_from_gaze`, 2x4."""
        rotations = self.head.rotation_with_derivatives(pan_rad, tilt_rad)
        return self._jacobian(rotations, *self._camera_ray(u_px, v_px))[0]

    def measure(self, sample: GazeSample, noise: MeasurementNoise) -> GroundMeasurement:
        """Ground position, velocity and their 4x4 covariance from one image measurement.

        Covariance F Σ F^T with F = [[J, 0], [d(J r)/dz, J]] (4x8), z = (pan, tilt, u, v),
        r = their rates, J = `ground_jacobian`. Column i of d(J r)/dz is Σ_j ∂²g/∂z_i∂z_j r_j,
        which by the symmetry of second derivatives is the derivative of J along r: one
        forward difference (J(z + εr) - J(z)) / ε, ε scaled so no input moves by more than
        its step, instead of one per input."""
        pan, tilt, u, v = sample.pan_rad, sample.tilt_rad, sample.u_px, sample.v_px
        rates = np.array(
            [sample.pan_rate_rad_s, sample.tilt_rate_rad_s, sample.u_rate_px_s, sample.v_rate_px_s]
        )
        ray = self._camera_ray(u, v)
        rotations = self.head.rotation_with_derivatives(pan, tilt)
        jacobian, direction = self._jacobian(rotations, *ray)
        hit = self.homography.ground_from_direction(direction)
        position = hit if self.height is None else self.height.target_from_hit(hit)
        reach = float((np.abs(rates) / INPUT_STEPS).max())  # steps per unit ε
        if reach > 0.0:
            epsilon = 1.0 / reach
            dz = epsilon * rates
            moved = self._camera_ray(u + dz[2], v + dz[3]) if dz[2] or dz[3] else ray
            # the estimator's samples carry no head rates (they drop out: observation.py)
            turned = (
                self.head.rotation_with_derivatives(pan + dz[0], tilt + dz[1])
                if dz[0] or dz[1]
                else rotations
            )
            velocity_by_z = (self._jacobian(turned, *moved)[0] - jacobian) / epsilon
        else:
            velocity_by_z = 0.0
        f = np.zeros((4, 8))
        f[:2, :4] = f[2:, 4:] = jacobian
        f[2:, :4] = velocity_by_z
        return GroundMeasurement(position, jacobian @ rates, (f * noise.variances()) @ f.T)

    def gaze_from_ground(self, x_m: float, y_m: float) -> tuple[float, float]:
        """Joint angles (pan, tilt) that centre the target at ground position (x, y) — any
        ground point, also one behind the frontal plane."""
        pan, tilt = self.head.angles_from_direction(self._direction_to(x_m, y_m))
        return float(pan), float(tilt)

    def gaze_jacobian(self, x_m: float, y_m: float) -> np.ndarray:
        """d(pan, tilt)/d(X, Y) of `gaze_from_ground`, 2x2."""
        return self._gaze_jacobian_at(self._direction_to(x_m, y_m))

    def gaze_rates_from_ground(
        self, x_m: float, y_m: float, x_rate_m_s: float, y_rate_m_s: float
    ) -> tuple[float, float]:
        """Joint rates (pan', tilt') that keep a target moving at (X', Y') centred."""
        _, _, pan_rate, tilt_rate = self.gaze_motion_from_ground(x_m, y_m, x_rate_m_s, y_rate_m_s)
        return pan_rate, tilt_rate

    def gaze_motion_from_ground(
        self, x_m: float, y_m: float, x_rate_m_s: float, y_rate_m_s: float
    ) -> tuple[float, float, float, float]:
        """(pan, tilt, pan', tilt'): `gaze_from_ground` and `gaze_rates_from_ground` from one
        ray to the ground point."""
        direction = self._direction_to(x_m, y_m)
        pan, tilt = self.head.angles_from_direction(direction)
        rates = self._gaze_jacobian_at(direction) @ np.array([x_rate_m_s, y_rate_m_s])
        return float(pan), float(tilt), float(rates[0]), float(rates[1])

    def _gaze_jacobian_at(self, direction: np.ndarray) -> np.ndarray:
        jacobian = self.head.direction_angles_jacobian(direction) @ self.homography.inverse[:, :2]
        return jacobian if self.height is None else jacobian / self.height.jacobian_scale

    def pixel_from_ground(
        self, x_m: float, y_m: float, pan_rad: float, tilt_rad: float
    ) -> np.ndarray:
        """Pixel (2,) where the target at ground position (x, y) appears with the head at
        (pan, tilt); raises ValueError if it is behind the camera."""
        direction = self._direction_to(x_m, y_m)
        return self.camera.pixel(self.head.camera_to_base(pan_rad, tilt_rad).T @ direction)

    def _camera_ray(self, u_px: float, v_px: float) -> tuple[np.ndarray, np.ndarray]:
        """The pixel's ray in the camera frame (y up) (3,) and its derivative by (u, v) (3x2)."""
        ray, ray_by_pixel = self.camera.ray_with_jacobian(u_px, v_px)
        return FLIP_Y @ ray, FLIP_Y @ ray_by_pixel

    def _jacobian(
        self, rotations: np.ndarray, ray: np.ndarray, ray_by_pixel: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """d(X, Y)/d(pan, tilt, u, v) (2x4) and the base-frame ray (3,), the head's rotation
        given as R, dR/dpan, dR/dtilt (`rotation_with_derivatives`)."""
        direction = rotations[0] @ ray
        ray_derivatives = np.empty((3, 4))
        ray_derivatives[:, :2] = (rotations[1:] @ ray).T
        ray_derivatives[:, 2:] = rotations[0] @ ray_by_pixel
        jacobian = self.homography.ground_jacobian(direction) @ ray_derivatives
        if self.height is not None:
            jacobian *= self.height.jacobian_scale
        return jacobian, direction

    def _direction_to(self, x_m: float, y_m: float) -> np.ndarray:
        target = np.array([x_m, y_m], dtype=float)
        hit = target if self.height is None else self.height.hit_from_target(target)
        return self.homography.direction_from_ground(hit)
