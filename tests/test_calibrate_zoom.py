"""`gazed calibrate zoom`: the command's steps against a scripted head whose zoom lens is known
(each view taken once the zoom has settled, the head back at its zoom at the end, the table
written into a rig), the refusals, and the option checks."""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np
import pytest
import tomlkit
from conftest import write_rig

from gazed.calibrate.head_session import CalibrationError
from gazed.calibrate.zoom_calibration import (
    ZoomRecorder,
    table_rows,
    write_zoom_table,
    zoom_command,
)
from gazed.calibrate.zoom_scale import zoom_table
from gazed.cli import main as cli_main
from gazed.config import load_rig
from gazed.messages import GazeDemand, Odometry
from gazed.sim.renderer import ground_texture
from gazed.vision.frames import CapturedFrame

SIZE = (320, 240)
FX_WIDE = 300.0
CENTRE = (159.5, 119.5)
TICK_NS = 20_000_000  # the scripted head's odometry period
FRAME_TICKS = 2  # a frame every other odometry reading
ZOOM_RATE_S = 0.8  # zoom range per second
TILT_RATE_RAD_S = 0.05  # slow: the zoom settles at its first position long before the tilt
TILT_HELD_RAD = -0.3


def lens(zoom: float) -> tuple[float, float, float]:
    """The scripted lens: fx grows eight times, the principal point wanders."""
    fx = FX_WIDE * 8.0**zoom
    return fx, CENTRE[0] + 5.0 * zoom, CENTRE[1] - 4.0 * zoom


class ScriptedHead:
    """A head session in simulated time: the zoom and the tilt move towards the demand at their
    rates, the odometry reports them every tick, and each frame shows the texture through the
    lens at the zoom of its exposure, shifted by the tilt's distance from TILT_HELD_RAD."""

    def __init__(self, zoom: float | None = 0.3, moves: bool = True, lag_ticks: int = 0) -> None:
        self.lag_ticks = lag_ticks  # the head acts on each demand this many ticks late
        self.t_ns = 10**18
        self.zoom = zoom
        self.moves = moves
        self.pan_rad, self.tilt_rad = 0.1, -0.2
        self.odometry: list[Odometry] = []
        self.demands: list[GazeDemand] = []
        self.scene = ground_texture(3)[300 : 300 + SIZE[1], 400 : 400 + SIZE[0]]
        self.ticks = 0

    def start(self, on_frame: object) -> Odometry:
        self._tick(None, on_frame)
        return self.odometry[-1]

    def pump(self, duration_s: float, demand: GazeDemand | None, on_frame, done=lambda: False):
        for _ in range(round(duration_s * 1e9 / TICK_NS)):
            self._tick(demand, on_frame)
            if done():
                return True
        return False

    def _tick(self, demand: GazeDemand | None, on_frame) -> None:
        self.t_ns += TICK_NS
        self.ticks += 1
        if demand is not None:
            self.demands.append(demand)
        if len(self.demands) > self.lag_ticks and demand is not None:
            demand = self.demands[-1 - self.lag_ticks]
            self.pan_rad = demand.pan_rad
            step = TILT_RATE_RAD_S * TICK_NS * 1e-9
            self.tilt_rad += float(np.clip(demand.tilt_rad - self.tilt_rad, -step, step))
            if demand.zoom is not None and self.zoom is not None and self.moves:
                step = ZOOM_RATE_S * TICK_NS * 1e-9
                self.zoom += float(np.clip(demand.zoom - self.zoom, -step, step))
        self.odometry.append(
            Odometry(
                t_capture_ns=self.t_ns, pan_rad=self.pan_rad, tilt_rad=self.tilt_rad, zoom=self.zoom
            )
        )
        if self.ticks % FRAME_TICKS == 0:
            on_frame(CapturedFrame(self._view(), "gray8", self.t_ns, self.ticks))

    def _view(self) -> np.ndarray:
        fx, cx, cy = lens(self.zoom or 0.0)
        s = fx / FX_WIDE
        dv = fx * (self.tilt_rad - TILT_HELD_RAD)  # the scene moves down as the head tilts up
        # x_z = s (x_0 - c_0) + c_z
        affine = np.array([[s, 0.0, cx - s * CENTRE[0]], [0.0, s, cy - s * CENTRE[1] + dv]])
        return cv2.warpAffine(self.scene, affine, SIZE, flags=cv2.INTER_CUBIC)


@pytest.fixture
def rig(tmp_path: Path):
    camera = f"[camera]\nwidth_px = {SIZE[0]}\nheight_px = {SIZE[1]}\nfx_px = {FX_WIDE}\n"
    return load_rig(write_rig(tmp_path, camera))


def test_the_table_is_the_lens_s_and_each_view_waits_for_the_head(rig) -> None:
    head = ScriptedHead()
    zooms = [0.0, 0.25, 0.5, 0.75, 1.0]
    recorder = ZoomRecorder(rig, head, settle_timeout_s=10.0)
    reached, views = recorder.record(zooms, None, TILT_HELD_RAD)
    assert reached == pytest.approx(zooms, abs=0.002)
    rows = zoom_table(reached, views, FX_WIDE, CENTRE)
    for row in rows:
        fx, cx, cy = lens(row.zoom)
        assert row.fx_px == pytest.approx(fx, rel=0.003)  # a view taken mid-zoom is far off
        assert (row.cx_px, row.cy_px) == pytest.approx((cx, cy), abs=0.5)  # or mid-tilt
    measuring = [d for d in head.demands if d.zoom in zooms]
    assert all((d.pan_rad, d.tilt_rad) == (0.1, TILT_HELD_RAD) for d in measuring)
    last = head.demands[-1]
    assert (last.pan_rad, last.tilt_rad, last.zoom) == (0.1, -0.2, 0.3)  # back where it started
    assert head.zoom == pytest.approx(0.3, abs=0.002)


def test_a_head_that_answers_late_is_waited_for(rig) -> None:
    """At the widest already, the head still and slow to start for the new pose: the first
    view waits until it has got there."""
    head = ScriptedHead(zoom=0.0, lag_ticks=25)
    reached, views = ZoomRecorder(rig, head, 10.0).record([0.0, 0.5], None, TILT_HELD_RAD)
    rows = zoom_table(reached, views, FX_WIDE, CENTRE)
    assert rows[1].fx_px == pytest.approx(lens(0.5)[0], rel=0.003)
    assert (rows[1].cx_px, rows[1].cy_px) == pytest.approx(lens(0.5)[1:], abs=0.5)


def test_a_head_without_zoom_is_refused(rig) -> None:
    with pytest.raises(CalibrationError, match="no zoom position"):
        ZoomRecorder(rig, ScriptedHead(zoom=None), 10.0).record([0.0, 1.0], None, None)


def test_a_zoom_that_does_not_settle_is_reported(rig) -> None:
    with pytest.raises(
        CalibrationError,
        match=r"did not settle at zoom 0\.000, pan 5\.73, tilt -11\.46 deg within 2 s",
    ):
        ZoomRecorder(rig, ScriptedHead(moves=False), 2.0).record([0.0, 1.0], None, None)


def test_the_table_is_written_into_the_rig_s_camera(tmp_path: Path, rig) -> None:
    rig_path = write_rig(tmp_path, "# my camera\n[camera]\nhfov_deg = 50.0\n")
    head = ScriptedHead()
    reached, views = ZoomRecorder(rig, head, 10.0).record([0.0, 0.5, 1.0], None, None)
    rows = table_rows(zoom_table(reached, views, FX_WIDE, CENTRE))
    write_zoom_table(rig_path, rows, "gazed calibrate zoom")
    text = rig_path.read_text()
    assert "# my camera" in text
    written = load_rig(rig_path).camera.zoom_focal_px
    assert written == rows
    assert written[-1][1] == pytest.approx(FX_WIDE * 8.0, rel=0.003)
    assert tomlkit.parse(text)["camera"]["hfov_deg"] == 50.0


@pytest.mark.parametrize("options", [["--positions", "1"], ["--settle-timeout-s", "0"]])
def test_bad_options_exit_2_before_the_bus(options: list[str], tmp_path: Path) -> None:
    rig_path = str(write_rig(tmp_path))
    assert cli_main(["calibrate", "zoom", "--rig", rig_path, *options]) == 2


def test_a_digital_head_has_no_lens_to_measure(capsys: pytest.CaptureFixture[str]) -> None:
    from conftest import REPO

    args = argparse.Namespace(
        rig=REPO / "configs" / "pets.toml",
        positions=3,
        pan_deg=None,
        tilt_deg=None,
        settle_timeout_s=5.0,
        write=None,
        json=False,
    )
    assert zoom_command(args) == 1
    assert "digital head" in capsys.readouterr().err
