"""`gazed servo jog`: check the wiring of a new head by sending one command and reading the
reply decoded.

    gazed servo jog --rig RIG --pan-deg 10 --tilt-deg -5    # joint angles, inside [head] limits
    gazed servo jog --rig RIG --stop
    gazed servo jog --rig RIG --query

An ONVIF camera is jogged over its own protocol (`onvif_jog`). Otherwise it opens the rig's
`[servo] port` (or `--port`, any pyserial URL), runs the protocol's start-up
handshake, writes the command's frames one by one and prints every byte sent and every reply
with its meaning, then listens for what the device sends unasked (VISCA completions, PTU limit
notices): until the completion of an acknowledged command is heard, at most `--listen-ms`.
Exit 0 when the head answered as the protocol says, 1 when the link or the device failed, 2 for
a bad rig or an angle outside the rig's limits.
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Hashable
from pathlib import Path

from gazed.config import Rig, load_rig_or_exit
from gazed.config.servo import OnvifServo
from gazed.geometry.kinematics import device_from_joint, joint_from_device
from gazed.servo import CODECS, CodecError, HandshakeError, Reply, make_codec
from gazed.servo.driver import ServoDriver
from gazed.servo.onvif_head import OnvifHead
from gazed.servo.onvif_jog import onvif_jog
from gazed.servo.transport import LinkError
from gazed.servo.visca_ip_transport import open_transport


def jog_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--rig", required=True, type=Path, help="rig description (TOML)")
    what = parser.add_mutually_exclusive_group(required=True)
    what.add_argument("--pan-deg", type=float, help="go to this pan (joint angle, with --tilt-deg)")
    what.add_argument("--stop", action="store_true", help="stop both axes where they are")
    what.add_argument("--query", action="store_true", help="read both axes' positions")
    parser.add_argument(
        "--tilt-deg", type=float, help="go to this tilt (joint angle, with --pan-deg)"
    )
    parser.add_argument(
        "--relative",
        action="store_true",
        help="ONVIF: move by --pan-deg/--tilt-deg from where the camera is (RelativeMove)",
    )
    parser.add_argument("--port", help="pyserial URL to use instead of the rig's [servo] port")
    parser.add_argument(
        "--listen-ms",
        type=float,
        default=300.0,
        help="after the command, print what the head sends unasked for this long at most, until "
        "an acknowledged command's completion is heard (default 300)",
    )


def jog_command(args: argparse.Namespace) -> int:
    rig = load_rig_or_exit(args.rig)
    if (args.pan_deg is None) != (args.tilt_deg is None):
        print("gazed servo jog: --pan-deg and --tilt-deg go together")
        return 2
    if args.pan_deg is not None and not args.relative:
        problem = _outside_limits(rig, args.pan_deg, args.tilt_deg)
        if problem:
            print(f"gazed servo jog: {problem}")
            return 2
    if isinstance(rig.servo, OnvifServo):
        servo = rig.servo.model_copy(update={"port": args.port}) if args.port else rig.servo
        folder = rig.source_path.parent if rig.source_path is not None else None
        return onvif_jog(rig, OnvifHead(servo, folder=folder), args)
    if args.relative:
        print("gazed servo jog: --relative is for ONVIF cameras")
        return 2
    if rig.servo.protocol not in CODECS:
        print(f"gazed servo jog: the {rig.servo.protocol} head has no serial port to jog")
        return 2
    port = args.port or rig.servo.port
    codec = make_codec(rig.servo.protocol, **rig.servo_params())
    timeout_s = rig.servo.timeout_ms / 1000
    driver = ServoDriver(codec, open_transport(port, rig.servo.baud, timeout_s), timeout_s)
    print(f"{rig.servo.protocol} on {port} at {rig.servo.baud} baud")
    try:
        with driver:
            print("handshake: ok")
            answered = _jog(rig, driver, args)
            _listen(driver, args.listen_ms / 1000.0, driver.codec.last_acked)
    except (LinkError, HandshakeError, CodecError) as exc:
        print(f"failed: {exc}")
        return 1
    return 0 if answered else 1


def _outside_limits(rig: Rig, pan_deg: float, tilt_deg: float) -> str | None:
    head = rig.head
    if not (math.isfinite(pan_deg) and math.isfinite(tilt_deg)):
        return "angles must be finite"
    if not head.pan_min_deg <= pan_deg <= head.pan_max_deg:
        return f"pan {pan_deg} deg outside [head] {head.pan_min_deg}..{head.pan_max_deg} deg"
    if not head.tilt_min_deg <= tilt_deg <= head.tilt_max_deg:
        return f"tilt {tilt_deg} deg outside [head] {head.tilt_min_deg}..{head.tilt_max_deg} deg"
    return None


def _jog(rig: Rig, driver: ServoDriver, args: argparse.Namespace) -> bool:
    """Send the command; False if the device answered with an error or cannot answer."""
    codec = driver.codec
    if args.query:
        if not codec.can_report_position:
            print("this head cannot report its position ([servo] position_feedback = false)")
            return False
        return _send(rig, driver, codec.encode_query_position())
    if args.stop:
        if codec.stop_needs_position and not _send(rig, driver, codec.encode_query_position()):
            return False
        return _send(rig, driver, codec.encode_stop())
    pan, tilt = device_from_joint(rig.head, math.radians(args.pan_deg), math.radians(args.tilt_deg))
    print(f"device angles: pan {math.degrees(pan):.3f} deg, tilt {math.degrees(tilt):.3f} deg")
    return _send(rig, driver, codec.encode_set_position(pan, tilt))


def _send(rig: Rig, driver: ServoDriver, frames: list[bytes]) -> bool:
    answered = True
    for frame in frames:
        print(f"-> {_show(frame)}")
        replies = driver.exchange(frame)
        if not replies:
            print("   (no reply expected)")
        for reply in replies:
            _print_reply(rig, reply)
            answered = answered and reply.kind != "error"
    return answered


def _listen(driver: ServoDriver, duration_s: float, acked: Hashable | None) -> None:
    """Print the notices that came during the exchanges, then whatever comes unasked for
    `duration_s`, or until the command acknowledged as `acked` has ended (its completion is
    heard): nothing more is due from it."""
    for reply in driver.notices:
        _print_read(reply)
    deadline = time.monotonic() + duration_s
    while not _ended(driver, acked) and (remaining_s := deadline - time.monotonic()) > 0:
        data, _ = driver.transport.read(remaining_s)
        for reply in driver.codec.feed(data):
            _print_read(reply)


def _ended(driver: ServoDriver, acked: Hashable | None) -> bool:
    """The command acknowledged as `acked` has ended (none was acknowledged: never)."""
    return acked is not None and not driver.codec.holds(acked)


def _print_read(reply: Reply) -> None:
    print(f"<- {_show(reply.raw)}   {reply.describe()}")


def _print_reply(rig: Rig, reply: Reply) -> None:
    _print_read(reply)
    if reply.kind == "position":
        pan, tilt = joint_from_device(
            rig.head,
            reply.pan_rad if reply.pan_rad is not None else math.nan,
            reply.tilt_rad if reply.tilt_rad is not None else math.nan,
        )
        joint = [
            f"{name} {math.degrees(angle):.3f} deg"
            for name, angle in (("pan", pan), ("tilt", tilt))
            if math.isfinite(angle)
        ]
        print(f"   joint: {', '.join(joint)}")


def _show(data: bytes) -> str:
    """ASCII protocols (PTU) as text, binary ones as hex."""
    if data and all(32 <= b < 127 or b in b"\r\n" for b in data):
        return repr(data.decode("ascii"))
    return data.hex(" ")
