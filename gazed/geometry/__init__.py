"""Geometry: camera model, head kinematics, frontal plane, homography, calibration (seed 000 §3).

Everything on the bus is in gazed joint angles (kinematics.py states the axis conventions),
radians, and ground coordinates in metres. Import the modules directly (this package imports
nothing, so `gazed.geometry.kinematics` does not pull in OpenCV).

Estimator and gaze — one object per rig, `ground.GroundGeometry`:

    geometry = GroundGeometry.from_rig(rig)   # MissingCalibrationError without a homography
    xy = geometry.ground_from_gaze(pan, tilt, u_px, v_px)           # (2,), height-corrected
    m = geometry.measure(GazeSample(pan, tilt, u, v, pan_rate, tilt_rate, u_rate, v_rate),
                         MeasurementNoise.from_head(rig.head, pixel_px=1.0, pixel_rate_px_s=5.0))
    m.position_m, m.velocity_m_s, m.covariance                      # (2,), (2,), 4x4 (X Y X' Y')
    geometry.ground_jacobian(pan, tilt, u, v)                       # 2x4 d(X, Y)/d(pan, tilt, u, v)
    pan, tilt = geometry.gaze_from_ground(x, y)                     # centre a ground point
    pan_rate, tilt_rate = geometry.gaze_rates_from_ground(x, y, x_rate, y_rate)
    pan, tilt, pan_rate, tilt_rate = geometry.gaze_motion_from_ground(x, y, x_rate, y_rate)  # both
    geometry.gaze_jacobian(x, y)                                    # 2x2 d(pan, tilt)/d(X, Y)
    geometry.pixel_from_ground(x, y, pan, tilt)                     # where it appears now

  `u_rate`, `v_rate` are the total rate of change of the target's pixel (ego-motion included).
  A ray at or above the horizon raises `homography.HorizonError` (a ValueError), never NaN.

Simulator and tests — the true pose, `pose.CameraPose`:

    pose = CameraPose.from_rig(rig)            # [sim] camera_xyz_m, camera_yaw_deg, [head]
    pose = CameraPose(np.array([x, y, z]), yaw_rad, pitch_rad=0.0, roll_rad=0.0, head=...)
    pose.frontal_to_ground()                   # the true GroundHomography (what calibrate finds)
    pan, tilt = pose.gaze_angles(points_m)     # (..., 3) world points, on the ground or at h
    pose.pixels(points_m, pan, tilt, camera)   # (..., 2), lens distortion included
    pose.ground_to_image(pan, tilt, camera)    # 3x3 H, pixel ≃ H (X, Y, 1) (pinhole part)
    pose.horizon_line(pan, tilt, camera)       # l · (u, v, 1) < 0 where the image sees ground
    pose.ground_geometry(camera, target_height_m)   # a GroundGeometry with the true M

Calibration (`gazed calibrate`, calibrate_cli.py):

    point_calibration.calibrate_points(points, head, limits, angle_noise_rad) -> CalibrationResult
    line_calibration.calibrate_lines(lines, head, limits) -> CalibrationResult
    result.homography.matrix, result.residuals_m, result.rms_m, result.max_m, result.outlier

Modules: camera (intrinsics, distortion, rays), kinematics (joint angles <-> rays and the
frontal plane), homography (frontal plane -> ground, canonical form), height (§3.1 height
correction), ground (GroundGeometry), pose (CameraPose), normalisation, degeneracy, calibration,
point_calibration (§3.1), line_calibration (§3.2), outlier, calibration_file, calibrate_cli.
"""
