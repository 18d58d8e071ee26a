"""ONVIF zoom: GetStatus's zoom position parsed from a reply in the specification's form, an
AbsoluteMove of the zoom alone, and the head link zooming the emulated camera (HTTP, SOAP,
WS-Security on loopback) from demands, its odometry carrying the zoom."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from onvif_support import Clock, onvif_rig
from servo_link_support import demand
from test_servo_onvif_head import SLOW_POLLS, head_on, link_on

from gazed.config import load_rig
from gazed.servo import onvif_ptz
from gazed.servo.codec import CodecError
from gazed.sim.head_onvif import OnvifEmulator

# the shape of the ONVIF PTZ Service Specification's GetStatus response (PTZStatus: Position
# with PanTilt and Zoom in their generic spaces, MoveStatus, UtcTime), as cameras send it
GET_STATUS = """<?xml version="1.0" encoding="UTF-8"?>
<s:Envelope xmlns:s="http://www.w3.org/2003/05/soap-envelope"
  xmlns:tptz="http://www.onvif.org/ver20/ptz/wsdl" xmlns:tt="http://www.onvif.org/ver10/schema">
<s:Body><tptz:GetStatusResponse><tptz:PTZStatus>
<tt:Position>
<tt:PanTilt x="0.25" y="-0.5" space="http://www.onvif.org/ver10/tptz/PanTiltSpaces/PositionGenericSpace"/>
<tt:Zoom x="0.375" space="http://www.onvif.org/ver10/tptz/ZoomSpaces/PositionGenericSpace"/>
</tt:Position>
<tt:MoveStatus><tt:PanTilt>IDLE</tt:PanTilt><tt:Zoom>MOVING</tt:Zoom></tt:MoveStatus>
<tt:UtcTime>2026-11-26T12:00:00Z</tt:UtcTime>
</tptz:PTZStatus></tptz:GetStatusResponse></s:Body></s:Envelope>"""


def test_get_status_carries_the_zoom_and_a_bad_zoom_is_garbage() -> None:
    status = onvif_ptz.parse_status(GET_STATUS)
    assert (status.pan, status.tilt, status.zoom) == (0.25, -0.5, 0.375)
    no_zoom = GET_STATUS.replace('<tt:Zoom x="0.375" space', "<tt:Foo space")
    assert onvif_ptz.parse_status(no_zoom).zoom is None
    with pytest.raises(CodecError, match="zoom"):
        onvif_ptz.parse_status(GET_STATUS.replace('x="0.375"', 'x="nan"'))


def test_get_status_without_the_zooms_x_is_garbage() -> None:
    with pytest.raises(CodecError, match="zoom unreadable"):
        onvif_ptz.parse_status(GET_STATUS.replace('<tt:Zoom x="0.375"', "<tt:Zoom"))


def test_an_absolute_move_of_the_zoom_leaves_pan_and_tilt_out() -> None:
    body = onvif_ptz.absolute_zoom("p", 0.5)
    assert '<tt:Zoom x="0.5"/>' in body and "PanTilt" not in body
    with pytest.raises(CodecError):
        onvif_ptz.absolute_zoom("p", math.inf)


def zoom_rig(tmp_path: Path, **servo: object):
    rig = onvif_rig(tmp_path, **servo)
    assert rig.source_path is not None
    text = rig.source_path.read_text().replace(
        "[camera]\n", "[camera]\nzoom_focal_px = [[0.0, 554.0], [1.0, 5540.0]]\n", 1
    )
    rig.source_path.write_text(text)
    return load_rig(rig.source_path)


def test_the_head_reads_the_zoom_space_and_zooms_the_emulated_camera(tmp_path: Path) -> None:
    rig, clock = zoom_rig(tmp_path), Clock()
    with OnvifEmulator(rig, clock=clock.now) as camera, head_on(rig, clock) as head:
        assert head.zoom_space == (0.0, 1.0)
        head.set_zoom(0.6)
        clock.sleep(3.0)
        head.query_position()
        assert head.query_zoom() == pytest.approx(0.6, abs=1e-9)
        assert camera.pose_at(clock.mono_s).zoom == pytest.approx(0.6)


def test_the_link_zooms_an_onvif_camera_and_its_odometry_follows(tmp_path: Path) -> None:
    rig, clock = zoom_rig(tmp_path, **SLOW_POLLS), Clock()
    with OnvifEmulator(rig, clock=clock.now) as camera:
        link, demands = link_on(rig, clock)
        readings = []
        for _ in range(150):  # 3 s
            demands.put(demand(0.0, 0.0).model_copy(update={"zoom": 0.7}))
            step = link.step(clock)
            if step.odometry is not None:
                readings.append(step.odometry)
            camera.pose_at(clock.mono_s)
            clock.sleep(0.02)
        assert link.link == "connected" and link.counts["errors"] == 0
        assert readings[0].zoom == pytest.approx(0.0, abs=1e-3)
        assert readings[-1].zoom == pytest.approx(0.7, abs=1e-3)
        assert camera.device.requests["AbsoluteMove"] <= 150 + 3.0 / 0.1 + 2
        link.close()
