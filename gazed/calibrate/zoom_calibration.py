"""`gazed calibrate zoom --rig RIG`: the rig's zoom table (`[camera] zoom_focal_px`) measured on
a still scene.

With the rig running and its gaze process off (`head_session`), the command holds the head's
pan and tilt (where it is, or `--pan-deg`/`--tilt-deg`) and steps the zoom from the widest
position to the longest (`--positions`, evenly spaced). At each position it waits until the
odometry reports the zoom settled there, then takes the first frame exposed after that (its
stamp less `[camera] delay_ms`). `zoom_scale.zoom_table` measures each view's scale and
principal point against the one before and chains them from the widest view, whose focal
length and principal point are the rig's `[camera]` (`fx_px` or `hfov_deg`, `cx_px`, `cy_px`).
The table is printed, and with `--write RIG` stored in the rig's `[camera]`. At the end the
head goes back to the pose and zoom it started at.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
from pathlib import Path

import numpy as np
import tomlkit

from gazed.calibrate.head_session import (
    CalibrationError,
    HeadSession,
    head_session,
    position_demand,
)
from gazed.calibrate.zoom_scale import ZoomMatchError, ZoomRow, zoom_table
from gazed.config import Rig, RigError, load_rig_or_exit
from gazed.geometry.calibrate_cli import replace_rig
from gazed.geometry.camera import CameraModel
from gazed.messages import GazeDemand, Odometry
from gazed.vision.frames import CapturedFrame, FrameError, gray_frame

ZOOM_TOLERANCE = 0.002  # of the zoom range: within this of the demand, the zoom has arrived
SETTLED_S = 0.3  # the reported zoom steady (within the tolerance) this long: settled
STILL_RAD = math.radians(0.02)  # and pan and tilt within this of each other meanwhile,
ARRIVED_RAD = math.radians(0.5)  # and this near the demand (a head's steps are coarser)


class ZoomRecorder:
    """Steps the zoom and keeps one view at each position."""

    def __init__(self, rig: Rig, session: HeadSession, settle_timeout_s: float) -> None:
        self.rig = rig
        self.session = session
        self.settle_timeout_s = settle_timeout_s
        self.latest: CapturedFrame | None = None

    def record(
        self, zooms: list[float], pan_rad: float | None, tilt_rad: float | None
    ) -> tuple[list[float], list[np.ndarray]]:
        """The zoom each view was taken at (as the head reported it) and the grey views."""
        start = self.session.start(self._frame)
        if start.zoom is None:
            raise CalibrationError(
                "the head reports no zoom position (a fixed lens, or a driver without zoom)"
            )
        pan = start.pan_rad if pan_rad is None else pan_rad
        tilt = start.tilt_rad if tilt_rad is None else tilt_rad
        reached, views = [], []
        try:
            for zoom in zooms:
                print(f"zoom {zoom:.3f}", file=sys.stderr)
                demand = position_demand(pan, tilt, zoom)
                reached.append(self._settle(demand, zoom))
                views.append(self._view_after(demand, self.session.odometry[-1].t_capture_ns))
        finally:  # back to where it started
            odometry = self.session.odometry

            def back() -> bool:
                return abs((odometry[-1].zoom or 0.0) - start.zoom) <= ZOOM_TOLERANCE

            home = position_demand(start.pan_rad, start.tilt_rad, start.zoom)
            self.session.pump(self.settle_timeout_s, home, self._frame, back)
        return reached, views

    def _frame(self, frame: CapturedFrame) -> None:
        self.latest = frame

    def _settle(self, demand: GazeDemand, zoom: float) -> float:
        """Drive to the demand until the odometry shows the zoom steady at `zoom` and the head
        still at the demand's pan and tilt; the zoom it reports."""
        odometry = self.session.odometry

        def settled() -> bool:
            recent = _since(odometry, odometry[-1].t_capture_ns - round(SETTLED_S * 1e9))
            spans = recent[-1].t_capture_ns - recent[0].t_capture_ns >= SETTLED_S * 1e9 * 0.9
            pans, tilts = [o.pan_rad for o in recent], [o.tilt_rad for o in recent]
            still = max(np.ptp(pans), np.ptp(tilts)) <= STILL_RAD
            there = (
                max(abs(pans[-1] - demand.pan_rad), abs(tilts[-1] - demand.tilt_rad)) <= ARRIVED_RAD
            )
            return (
                spans
                and still
                and there
                and all(o.zoom is not None and abs(o.zoom - zoom) <= ZOOM_TOLERANCE for o in recent)
            )

        if not self.session.pump(self.settle_timeout_s, demand, self._frame, settled):
            last = odometry[-1]
            raise CalibrationError(
                f"the head did not settle at zoom {zoom:.3f}, pan "
                f"{math.degrees(demand.pan_rad):.2f}, tilt {math.degrees(demand.tilt_rad):.2f} deg "
                f"within {self.settle_timeout_s:g} s (it reports zoom {last.zoom}, pan "
                f"{math.degrees(last.pan_rad):.2f}, tilt {math.degrees(last.tilt_rad):.2f} deg)"
            )
        recent = _since(odometry, odometry[-1].t_capture_ns - round(SETTLED_S * 1e9))
        return round(float(np.mean([o.zoom for o in recent])), 4)

    def _view_after(self, demand: GazeDemand, settled_ns: int) -> np.ndarray:
        """The grey view of the first frame exposed after `settled_ns` (the odometry's wall
        clock), the demand held meanwhile."""
        camera = self.rig.camera
        after_ns = settled_ns + round(camera.delay_ms * 1e6)
        self.latest = None

        def exposed() -> bool:
            return self.latest is not None and self.latest.t_capture_ns >= after_ns

        wait_s = camera.timeout_ms * 1e-3 + camera.delay_ms * 1e-3
        if not self.session.pump(wait_s, demand, self._frame, exposed) or self.latest is None:
            raise CalibrationError(f"no frame from the camera within {wait_s:g} s")
        try:
            return gray_frame(self.latest, camera.width_px, camera.height_px)
        except FrameError as exc:
            raise CalibrationError(f"the camera's frame is not the rig's: {exc}") from exc


def _since(odometry: list[Odometry], t_ns: int) -> list[Odometry]:
    """The readings from `t_ns` on (the list is in arrival order, the stamps rising)."""
    k = len(odometry)
    while k > 0 and odometry[k - 1].t_capture_ns >= t_ns:
        k -= 1
    return odometry[k:] or odometry[-1:]


def measure(rig: Rig, args: argparse.Namespace) -> list[ZoomRow]:
    """Record the views on the running rig and measure the table from them."""
    if rig.servo.protocol == "digital":
        raise CalibrationError(
            "a digital head renders its views with a known camera: no zoom lens to measure"
        )
    zooms = [float(z) for z in np.linspace(0.0, 1.0, args.positions)]
    pan = None if args.pan_deg is None else math.radians(args.pan_deg)
    tilt = None if args.tilt_deg is None else math.radians(args.tilt_deg)
    with head_session(rig) as session:
        reached, views = ZoomRecorder(rig, session, args.settle_timeout_s).record(zooms, pan, tilt)
    if any(b <= a for a, b in itertools.pairwise(reached)):
        raise CalibrationError(f"the zoom positions the head reached do not rise: {reached}")
    base = CameraModel.from_section(rig.camera)
    try:
        return zoom_table(reached, views, base.K[0, 0], (base.K[0, 2], base.K[1, 2]))
    except ZoomMatchError as exc:
        raise CalibrationError(
            f"{exc} (point the head at a textured, still scene, or use more --positions)"
        ) from exc


def table_rows(rows: list[ZoomRow]) -> list[list[float]]:
    """The rows of `[camera] zoom_focal_px`: zoom, fx_px, cx_px, cy_px."""
    return [
        [row.zoom, round(row.fx_px, 2), round(row.cx_px, 2), round(row.cy_px, 2)] for row in rows
    ]


def write_zoom_table(rig_path: Path, rows: list[list[float]], note: str) -> None:
    """Set [camera] zoom_focal_px in a rig file, keeping its comments and layout."""
    document = tomlkit.parse(rig_path.read_text(encoding="utf-8"))
    table = tomlkit.array()
    table.multiline(True)
    for row in rows:
        table.append(row)
    table.comment(note)
    if "camera" not in document:
        document["camera"] = tomlkit.table()
    document["camera"]["zoom_focal_px"] = table
    replace_rig(rig_path, document)


def zoom_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--rig", required=True, type=Path, help="the running rig (TOML)")
    parser.add_argument(
        "--positions", type=int, default=11, help="zoom positions, widest to longest (11)"
    )
    parser.add_argument("--pan-deg", type=float, help="pan to hold (default: where it is)")
    parser.add_argument("--tilt-deg", type=float, help="tilt to hold (default: where it is)")
    parser.add_argument(
        "--settle-timeout-s", type=float, default=30.0, help="longest wait per position (30)"
    )
    parser.add_argument(
        "--write", type=Path, metavar="RIG", help="store the table in this rig's [camera]"
    )
    parser.add_argument("--json", action="store_true", help="print JSON")


def zoom_command(args: argparse.Namespace) -> int:
    rig = load_rig_or_exit(args.rig)
    if not (2 <= args.positions <= 64 and 0 < args.settle_timeout_s <= 600):
        print("gazed calibrate zoom: --positions 2-64, --settle-timeout-s 0-600", file=sys.stderr)
        return 2
    try:
        rows = measure(rig, args)
    except CalibrationError as exc:
        print(f"gazed calibrate zoom: {exc}", file=sys.stderr)
        return 1
    table = table_rows(rows)
    if args.json:
        print(json.dumps([row.__dict__ for row in rows], indent=2))
    else:
        print(f"{'zoom':>6} {'fx_px':>9} {'cx_px':>7} {'cy_px':>7} {'scale':>7} {'match':>6}")
        for row in rows:
            print(
                f"{row.zoom:>6.3f} {row.fx_px:>9.1f} {row.cx_px:>7.1f} {row.cy_px:>7.1f} "
                f"{row.scale:>7.3f} {row.correlation:>6.3f}"
            )
        print(f"[camera] zoom_focal_px = {json.dumps(table)}")
    if args.write is not None:
        note = f"gazed calibrate zoom: {len(rows)} positions, {rows[-1].scale:.2f}x"
        try:
            write_zoom_table(args.write, table, note)
        except (OSError, RigError) as exc:
            print(f"gazed calibrate zoom: cannot write {args.write}: {exc}", file=sys.stderr)
            return 2
        print(f"wrote [camera] zoom_focal_px to {args.write}", file=sys.stderr)
    return 0
