"""From a detection to an estimator measurement (seed 000 §2-3, §6).

A detection gives the target's pixel p and its *independent* image velocity ṙ_ind (the head's
rotational flow ṙ_rot already removed, seed 000 §2), with the head pose at capture. For any
map g(angles, p) of a world point (its ground position, or the angles that centre it), a point
fixed in the world has dg/dt = J_angles ω + J_p ṙ_rot = 0, so for the target

    dg/dt = J_angles ω + J_p (ṙ_ind + ṙ_rot) = J_p ṙ_ind,

and the head's rates drop out: the velocity measurement needs only the pixel Jacobian.

- ground modes: position from `GroundGeometry.ground_from_gaze` (height-corrected), velocity
  J_p ṙ_ind, covariance propagated from the head's angle noise and the detector's pixel noise;
- `image-cv` (the 2D baseline): the joint angles that would centre the target, and their rates.
"""

from __future__ import annotations

import numpy as np

from gazed.estimation.measurement import Measurement
from gazed.geometry.camera import CameraModel
from gazed.geometry.ground import GazeSample, GroundGeometry, MeasurementNoise
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.target_angles import target_angles
from gazed.messages import Detection, HeadPose


def ground_measurement(
    detection: Detection, geometry: GroundGeometry, noise: MeasurementNoise
) -> Measurement:
    """The ground position and velocity of a found target; raises ValueError (HorizonError)
    for a pixel whose ray does not meet the ground, and without a head pose."""
    head = _head(detection)
    sample = GazeSample(
        pan_rad=head.pan_rad,
        tilt_rad=head.tilt_rad,
        u_px=detection.u_px,
        v_px=detection.v_px,
        u_rate_px_s=detection.du_px_s,
        v_rate_px_s=detection.dv_px_s,
    )
    ground = geometry.measure(sample, noise)
    cov = ground.covariance
    return Measurement.ground(
        detection.t_capture_ns / 1e9,
        ground.position_m,
        cov[:2, :2],
        ground.velocity_m_s,
        cov[2:, 2:],
    )


def gaze_measurement(
    detection: Detection, camera: CameraModel, kinematics: HeadKinematics, noise: MeasurementNoise
) -> Measurement:
    """The joint angles that centre the target and their rates (the observer trajectory)."""
    head = _head(detection)
    target = target_angles(
        camera, kinematics, head.pan_rad, head.tilt_rad, detection.u_px, detection.v_px
    )
    rates = target.rates(detection.du_px_s, detection.dv_px_s)
    j = target.pixel_jacobian
    angle_cov = noise.angle_rad**2 * np.eye(2) + (j * noise.pixel_variances()) @ j.T
    rate_cov = noise.angle_rate_rad_s**2 * np.eye(2) + noise.pixel_rate_px_s**2 * j @ j.T
    return Measurement.gaze(
        detection.t_capture_ns / 1e9, (target.pan_rad, target.tilt_rad), angle_cov, rates, rate_cov
    )


def _head(detection: Detection) -> HeadPose:
    if detection.head is None:
        raise ValueError("the detection has no head pose (no odometry at capture)")
    return detection.head
