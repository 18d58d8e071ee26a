"""The chosen person among a frame's movers: the gaze follows one track, while vision names the
target it sees (`Detection.u_px`, the first mover). Where a frame shows several movers and the
chosen track has a prediction, the detection the gaze uses is the mover nearest where that
prediction puts the track at the frame's capture (by the angle between their gaze directions),
so that a person crossing in front does not feed the pursuit's residual or its sightings."""

from __future__ import annotations

from gazed.gaze.aim import Aim, angle_between
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.target_angles import target_angles
from gazed.geometry.zoom import ZoomLens
from gazed.messages import Detection, Prediction


def focus(
    detection: Detection,
    prediction: Prediction | None,
    lens: ZoomLens,
    kinematics: HeadKinematics,
) -> Detection:
    """The detection with the chosen track's mover as its target; unchanged where vision found
    no target, with fewer than two movers, without a head pose or without a prediction."""
    head = detection.head
    if not detection.found or len(detection.movers) < 2 or head is None or prediction is None:
        return detection
    pan, tilt = Aim.of_prediction(prediction).at(detection.t_capture_ns)
    camera = lens.at_pose(head)

    def off_rad(k: int) -> float:
        mover = detection.movers[k]
        seen = target_angles(
            camera, kinematics, head.pan_rad, head.tilt_rad, mover.u_px, mover.v_px
        )
        return angle_between(seen.pan_rad, seen.tilt_rad, pan, tilt, kinematics)

    nearest = min(range(len(detection.movers)), key=off_rad)
    if nearest == 0:
        return detection
    mover = detection.movers[nearest]
    return detection.model_copy(
        update={
            "u_px": mover.u_px,
            "v_px": mover.v_px,
            "du_px_s": mover.du_px_s,
            "dv_px_s": mover.dv_px_s,
            "area_px": mover.area_px,
            "confidence": mover.confidence,
        }
    )
