"""ONVIF zoom on a head link, against the emulated ONVIF camera on loopback on a virtual clock:
the link zooms at the rig's rate in position and in speed mode (the zoom's AbsoluteMove leaves
the pan/tilt moves alone), its odometry follows the lens, closing it parks the lens at its
widest view; a rig without a zoom lens reports no zoom and sends none. A zoom during a
ContinuousMove sends the move again, as some cameras (ipycam) end it on any AbsoluteMove."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import pytest
from onvif_support import Clock, onvif_rig
from servo_link_support import demand
from test_servo_onvif_head import SLOW_POLLS, head_on, link_on, run

from gazed.config import Rig, load_rig
from gazed.sim.head_onvif import OnvifEmulator

ZOOM_TABLE = "zoom_focal_px = [[0.0, 554.0], [1.0, 2216.0]]"


def zoom_rig(tmp_path: Path, **servo: object) -> Rig:
    """The sim ONVIF rig with a zoom lens, zooming across its range in two seconds."""
    path = onvif_rig(tmp_path, **servo).source_path
    assert path is not None
    text = path.read_text().replace("[camera]\n", f"[camera]\n{ZOOM_TABLE}\n", 1)
    path.write_text(text.replace("[head]\n", "[head]\nzoom_rate_max_s = 0.5\n", 1))
    return load_rig(path)


@pytest.mark.parametrize("mode", ["position", "speed"])
def test_a_link_zooms_at_the_rigs_rate_reports_it_and_parks_wide(tmp_path: Path, mode: str) -> None:
    rig = zoom_rig(tmp_path, mode=f'"{mode}"', command_timeout_ms=300.0, **SLOW_POLLS)
    clock = Clock()
    with OnvifEmulator(rig, clock=clock.now) as camera:
        link, demands = link_on(rig, clock)
        odometry = []

        def steps(seconds: float, zoom: float) -> None:
            end_s = clock.mono_s + seconds
            while clock.mono_s < end_s:
                demands.put(demand(15.0, -5.0).model_copy(update={"zoom": zoom}))
                reading = link.step(clock).odometry
                if reading is not None:
                    odometry.append(reading)
                clock.sleep(0.04)

        steps(0.6, 0.6)
        assert link.link == "connected" and link.zoom is not None
        assert 0.15 < odometry[-1].zoom < 0.4  # 0.5 a second from 0
        steps(0.9, 0.6)
        assert odometry[-1].zoom == pytest.approx(0.6, abs=1e-3)
        zooms = [r.zoom for r in odometry]
        assert all(b >= a - 1e-9 for a, b in itertools.pairwise(zooms))
        assert math.degrees(odometry[-1].pan_rad) == pytest.approx(15.0, abs=1.0)
        steps(0.1, -3.0)  # clamped to the widest
        assert link.zoom.target == 0.0
        assert link.counters()["errors"] == 0
        link.close()
        camera.device.advance(clock.mono_s + 3.0)
        assert camera.mechanics.zoom.position_rad == pytest.approx(0.0)
        assert camera.pose_at(clock.mono_s + 3.0).zoom == pytest.approx(0.0)


def test_a_rig_without_a_zoom_lens_reports_no_zoom(tmp_path: Path) -> None:
    rig, clock = onvif_rig(tmp_path, **SLOW_POLLS), Clock()
    with OnvifEmulator(rig, clock=clock.now) as camera:
        link, demands = link_on(rig, clock)
        demands.put(demand(5.0, 0.0).model_copy(update={"zoom": 0.7}))
        run(link, clock, 0.3, camera)
        assert link.zoom is None
        readings = []
        for _ in range(10):
            clock.sleep(0.05)
            readings.append(link.step(clock).odometry)
        assert any(r is not None for r in readings)
        assert all(r.zoom is None for r in readings if r is not None)
        assert camera.pose_at(clock.mono_s).zoom is None
        link.close()
        assert camera.mechanics.zoom.target_rad == 0.0  # the demand's zoom never went out


def test_a_zoom_during_a_continuous_move_sends_the_move_again_for_what_remains(
    tmp_path: Path,
) -> None:
    rig, clock = zoom_rig(tmp_path), Clock()
    with OnvifEmulator(rig, clock=clock.now) as camera, head_on(rig, clock) as head:
        requests = camera.device.requests
        head.set_speed(0.5, 0.0, 1.0)
        clock.sleep(0.4)
        head.set_zoom(0.3)
        assert (requests["AbsoluteMove"], requests["ContinuousMove"]) == (1, 2)
        assert camera.device.continuous_until_s == pytest.approx(clock.mono_s + 0.6, abs=1e-3)
        head.stop()
        head.set_zoom(0.5)  # nothing running: nothing sent again
        head.set_speed(0.0, -0.5, 0.3)
        clock.sleep(0.4)
        head.set_zoom(0.1)  # its timeout has run out: the camera has stopped it itself
        head.set_speed(0.5, 0.0, 1.0)
        head.set_position(0.0, 0.0)
        head.set_zoom(0.2)  # an AbsoluteMove of pan and tilt has ended it
        assert (requests["AbsoluteMove"], requests["ContinuousMove"]) == (5, 4)
