"""`gazed calibrate tsai FILE.xml --size WxH [--write RIG]`: a Tsai calibration (PETS, Willson's
XML) as a rig's wide camera and ground geometry.

It prints, as TOML, `[wide]`'s size, intrinsics and OpenCV distortion fitted to the Tsai lens,
and `[calibration]`'s homography (gazed's frontal plane of a head turning about the camera's
centre, at rest along its optical axis, to the ground) and `camera_xyz_m`: the rig's ground
frame is the calibration's world frame, in metres. With `--write` those keys are set in the rig
file, its comments kept. The distortion fit's largest error (pixels) is printed too.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path
from typing import Any

import tomlkit

from gazed.config import RigError
from gazed.geometry.calibrate_cli import replace_rig
from gazed.geometry.tsai import TsaiCamera, TsaiError


def tsai_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", type=Path, metavar="FILE.xml", help="Tsai calibration (XML)")
    parser.add_argument(
        "--size",
        required=True,
        metavar="WxH",
        help="the size of the images the rig gets (the calibration is scaled to it)",
    )
    parser.add_argument(
        "--write", type=Path, metavar="RIG", help="set the keys in this rig, keeping its comments"
    )


def tsai_keys(camera: TsaiCamera) -> tuple[dict[str, dict[str, Any]], float]:
    """The rig keys of a Tsai camera, by section, and the distortion fit's largest error (px)."""
    distortion, error_px = camera.opencv_distortion()
    wide = {
        "width_px": camera.width_px,
        "height_px": camera.height_px,
        "fx_px": float(camera.fx_px),
        "fy_px": float(camera.fy_px),
        "cx_px": float(camera.cx_px),
        "cy_px": float(camera.cy_px),
        "distortion": [float(k) for k in distortion],
    }
    calibration = {
        "homography": [[float(v) for v in row] for row in camera.ground_homography()],
        "camera_xyz_m": [float(v) for v in camera.camera_xyz_m],
    }
    return {"wide": wide, "calibration": calibration}, error_px


def tsai_command(args: argparse.Namespace) -> int:
    size = re.fullmatch(r"(\d+)x(\d+)", args.size)
    if size is None:
        print(f"gazed calibrate tsai: --size {args.size!r}: expected WxH", file=sys.stderr)
        return 2
    try:
        camera = TsaiCamera.from_xml(args.file).scaled(int(size[1]), int(size[2]))
    except TsaiError as exc:
        print(f"gazed calibrate tsai: {exc}", file=sys.stderr)
        return 2
    sections, error_px = tsai_keys(camera)
    note = (
        f"gazed calibrate tsai {args.file} --size {args.size}: distortion fit max {error_px:.3f} px"
    )
    document = tomlkit.document()
    document.add(tomlkit.comment(note))
    for name, keys in sections.items():
        document[name] = keys
    document["calibration"]["homography"].multiline(True)
    print(tomlkit.dumps(document), end="")
    if args.write is not None:
        try:
            rig = tomlkit.parse(args.write.read_text(encoding="utf-8"))
            for name, keys in sections.items():
                if name not in rig:
                    rig[name] = tomlkit.table()
                for key, value in keys.items():
                    rig[name][key] = value
            rig["calibration"]["homography"].multiline(True).comment(note)
            replace_rig(args.write, rig)
        except (OSError, RigError) as exc:
            print(f"gazed calibrate tsai: cannot write {args.write}: {exc}", file=sys.stderr)
            return 2
        print(f"wrote [wide] and [calibration] to {args.write}", file=sys.stderr)
    return 0
