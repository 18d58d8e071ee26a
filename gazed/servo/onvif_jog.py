"""`gazed servo jog` on an ONVIF camera: connect, show what the camera offers, send one command
and show the position it reports, in the camera's own units and in degrees.

The camera's units are what the rig's `pan_range_deg`/`tilt_range_deg` are measured against:
`--query` prints the generic pan/tilt beside the angles the present ranges make of them, so two
readings at known angles give the two ends of each range (docs/servo.md).
"""

from __future__ import annotations

import argparse
import math
import time

from gazed.config import Rig
from gazed.geometry.kinematics import device_from_joint, joint_from_device
from gazed.servo.codec import CodecError, HandshakeError
from gazed.servo.driver import DeviceError
from gazed.servo.onvif_head import OnvifHead
from gazed.servo.transport import LinkError


def onvif_jog(rig: Rig, camera: OnvifHead, args: argparse.Namespace) -> int:
    """Run one jog on `camera`; the exit status of `gazed servo jog`."""
    print(f"onvif on {camera.servo.port} as {camera.servo.username}")
    try:
        with camera:
            _describe(camera)
            if args.stop:
                camera.stop()
                print("-> Stop")
            elif args.pan_deg is not None and args.relative:
                if not _relative_move(rig, camera, args.pan_deg, args.tilt_deg):
                    return 2
            elif args.pan_deg is not None:
                pan, tilt = device_from_joint(
                    rig.head, math.radians(args.pan_deg), math.radians(args.tilt_deg)
                )
                camera.set_position(pan, tilt)
                print(
                    f"-> AbsoluteMove to device pan {math.degrees(pan):.3f} deg, "
                    f"tilt {math.degrees(tilt):.3f} deg"
                )
            time.sleep(args.listen_ms / 1000.0)
            _report(rig, camera)
    except (LinkError, HandshakeError, DeviceError, CodecError) as exc:
        print(f"failed: {exc}")
        return 1
    return 0


def _relative_move(rig: Rig, camera: OnvifHead, pan_deg: float, tilt_deg: float) -> bool:
    """RelativeMove by joint angles, refused if it would end outside `[head]`'s limits."""
    head = rig.head
    at = camera.query_position()
    pan, tilt = joint_from_device(head, at.pan_rad, at.tilt_rad)
    to_pan, to_tilt = math.degrees(pan) + pan_deg, math.degrees(tilt) + tilt_deg
    if not (
        math.isfinite(to_pan)
        and math.isfinite(to_tilt)
        and head.pan_min_deg <= to_pan <= head.pan_max_deg
        and head.tilt_min_deg <= to_tilt <= head.tilt_max_deg
    ):
        print(
            f"gazed servo jog: the move would end at pan {to_pan:.3f}, tilt {to_tilt:.3f} deg, "
            "outside [head]'s limits"
        )
        return False
    camera.move_by(head.pan_sign * math.radians(pan_deg), head.tilt_sign * math.radians(tilt_deg))
    print(f"-> RelativeMove by pan {pan_deg} deg, tilt {tilt_deg} deg")
    return True


def _describe(camera: OnvifHead) -> None:
    caps, pan, tilt = camera.capabilities, camera.pan_space, camera.tilt_space
    assert caps is not None and pan is not None and tilt is not None
    moves = [
        name
        for name, has in (
            ("absolute", caps.absolute),
            ("relative", caps.relative),
            ("continuous", caps.continuous),
        )
        if has
    ]
    print(f"profile {camera.profile}: moves {', '.join(moves) or 'none'}")
    print(f"absolute pan {pan.low}..{pan.high}, tilt {tilt.low}..{tilt.high}")


def _report(rig: Rig, camera: OnvifHead) -> None:
    pan, tilt = camera.pan_space, camera.tilt_space
    assert pan is not None and tilt is not None
    position = camera.query_position()
    joint_pan, joint_tilt = joint_from_device(rig.head, position.pan_rad, position.tilt_rad)
    print(
        f"<- GetStatus pan {pan.to_space(position.pan_rad):.5f}, "
        f"tilt {tilt.to_space(position.tilt_rad):.5f} (camera units), {camera.last_status}"
    )
    print(
        f"   joint: pan {math.degrees(joint_pan):.3f} deg, tilt {math.degrees(joint_tilt):.3f} deg"
    )
