"""ONVIF PTZ without I/O: the WS-Security digest against the ONVIF Application Programmer's
Guide's worked example, request bodies against ptz.wsdl's elements, GetStatus replies (the
schema's, ipycam's with undeclared prefixes and a template for MoveStatus, garbage), the map
between the camera's units and degrees, and the emulated camera's authentication of onveef's
own envelopes."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st
from onveef import envelopes

from gazed.servo import onvif_ptz
from gazed.servo.codec import CodecError
from gazed.servo.onvif_ptz import AxisSpace, parse_status
from gazed.sim.onvif_device import password_digest

STATUS = """<?xml version="1.0" encoding="UTF-8"?>
<s:Envelope xmlns:s="http://www.w3.org/2003/05/soap-envelope" xmlns:tt="http://www.onvif.org/ver10/schema"
 xmlns:tptz="http://www.onvif.org/ver20/ptz/wsdl"><s:Body><tptz:GetStatusResponse><tptz:PTZStatus>
 <tt:Position><tt:PanTilt x="0.25" y="-0.5" space="http://www.onvif.org/ver10/tptz/PanTiltSpaces/PositionGenericSpace"/>
  <tt:Zoom x="0.1" space="http://www.onvif.org/ver10/tptz/ZoomSpaces/PositionGenericSpace"/></tt:Position>
 <tt:MoveStatus><tt:PanTilt>MOVING</tt:PanTilt><tt:Zoom>IDLE</tt:Zoom></tt:MoveStatus>
 <tt:UtcTime>2026-01-01T00:00:00Z</tt:UtcTime></tptz:PTZStatus></tptz:GetStatusResponse></s:Body></s:Envelope>"""

# ipycam 1.3.0: the ptz: prefix undeclared, MoveStatus a template placeholder
IPYCAM_STATUS = """<?xml version="1.0" encoding="UTF-8"?>
<s:Envelope xmlns:s="http://www.w3.org/2003/05/soap-envelope" xmlns:tds="http://www.onvif.org/ver10/device/wsdl"
 xmlns:tt="http://www.onvif.org/ver10/schema" xmlns:trt="http://www.onvif.org/ver10/media/wsdl"><s:Body>
 <ptz:GetStatusResponse><ptz:PTZStatus><tt:Position><tt:PanTilt x="0.2" y="-0.1"/>\
<tt:Zoom x="0.5"/></tt:Position>
 <tt:MoveStatus><tt:PanTilt>{{pan_tilt_status}}</tt:PanTilt><tt:Zoom>{{zoom_status}}</tt:Zoom></tt:MoveStatus>
 <tt:UtcTime>{{utc_time}}</tt:UtcTime></ptz:PTZStatus></ptz:GetStatusResponse></s:Body></s:Envelope>"""


def test_password_digest_matches_the_programmers_guide_example() -> None:
    digest = password_digest("LKqI6G/AikKCQrN0zqZFlg==", "2010-09-16T07:50:45Z", "userpassword")
    assert digest == "tuOSpGlFlIXsozq4HFNeeGeFLEI="


def test_request_bodies_carry_both_axes_as_ptz_wsdl_names_them() -> None:
    assert onvif_ptz.absolute_move("Profile_Main", 0.25, -0.5) == (
        "<tptz:AbsoluteMove><tptz:ProfileToken>Profile_Main</tptz:ProfileToken><tptz:Position>"
        '<tt:PanTilt x="0.25" y="-0.5"/></tptz:Position></tptz:AbsoluteMove>'
    )
    assert onvif_ptz.continuous_move("P", 0.5, 0.0, 1.0) == (
        "<tptz:ContinuousMove><tptz:ProfileToken>P</tptz:ProfileToken><tptz:Velocity>"
        '<tt:PanTilt x="0.5" y="0.0"/></tptz:Velocity><tptz:Timeout>PT1.000S</tptz:Timeout>'
        "</tptz:ContinuousMove>"
    )
    assert onvif_ptz.stop("P") == (
        "<tptz:Stop><tptz:ProfileToken>P</tptz:ProfileToken><tptz:PanTilt>true</tptz:PanTilt>"
        "<tptz:Zoom>false</tptz:Zoom></tptz:Stop>"
    )
    assert onvif_ptz.goto_preset("P", "1") == (
        "<tptz:GotoPreset><tptz:ProfileToken>P</tptz:ProfileToken><tptz:PresetToken>1"
        "</tptz:PresetToken></tptz:GotoPreset>"
    )
    assert '<tt:PanTilt x="0.0" y="0.1"/>' in onvif_ptz.relative_move("P", 0.0, 0.1)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_a_non_finite_move_is_refused_before_it_is_written(bad: float) -> None:
    with pytest.raises(CodecError):
        onvif_ptz.absolute_move("P", bad, 0.0)
    with pytest.raises(CodecError):
        onvif_ptz.continuous_move("P", 0.0, bad, 1.0)


def test_get_status_of_the_schema_is_read() -> None:
    assert parse_status(STATUS) == onvif_ptz.PtzStatus(0.25, -0.5, "MOVING", zoom=0.1)
    assert parse_status(STATUS.replace("MOVING", "IDLE")).move_status == "IDLE"


def test_ipycams_undeclared_prefix_is_declared_and_its_placeholder_status_is_unknown() -> None:
    assert parse_status(IPYCAM_STATUS) == onvif_ptz.PtzStatus(0.2, -0.1, "UNKNOWN", zoom=0.5)


@pytest.mark.parametrize(
    "reply",
    [
        "\x00\xffnot xml",
        STATUS.replace('x="0.25" ', ""),
        STATUS.replace('x="0.25"', 'x="nan"'),
        STATUS.replace("tt:Position>", "tt:Elsewhere>"),
        '<?xml version="1.0"?><!DOCTYPE x [<!ENTITY a "aaaa">]><x>&a;</x>',
    ],
)
def test_a_status_reply_without_a_readable_position_is_a_codec_error(reply: str) -> None:
    with pytest.raises(CodecError):
        parse_status(reply)


@given(st.text(max_size=300))
def test_any_text_is_a_status_or_a_codec_error(text: str) -> None:
    try:
        status = parse_status(text)
    except CodecError:
        return
    assert math.isfinite(status.pan) and math.isfinite(status.tilt)


@given(
    st.floats(-1.0, 1.0),
    st.sampled_from([(-1.0, 1.0), (0.0, 1.0), (-100.0, 100.0)]),
    st.sampled_from([(-170.0, 170.0), (170.0, -170.0), (0.0, 350.0)]),
)
def test_units_and_degrees_map_both_ways(w: float, units, degrees) -> None:
    space = AxisSpace(*units, *(math.radians(d) for d in degrees))
    value = units[0] + (w + 1.0) / 2.0 * (units[1] - units[0])
    assert space.to_space(space.to_rad(value)) == pytest.approx(value, abs=1e-9)


def test_angles_past_the_range_are_clamped_to_its_ends() -> None:
    space = AxisSpace(0.0, 1.0, math.radians(-170.0), math.radians(170.0))
    assert space.to_space(math.radians(0.0)) == pytest.approx(0.5)
    assert space.to_space(math.radians(400.0)) == 1.0
    assert space.to_space(math.radians(-400.0)) == 0.0


def test_durations() -> None:
    assert onvif_ptz.duration_s("PT0.5S") == 0.5
    assert onvif_ptz.duration_s("PT1M30S") == 90.0
    with pytest.raises(CodecError):
        onvif_ptz.duration_s("soon")


def test_the_emulated_camera_takes_onveefs_digest_and_refuses_others(tmp_path) -> None:
    from onvif_support import PASSWORD, onvif_rig

    from gazed.sim.head_mechanics import HeadMechanics
    from gazed.sim.onvif_device import OnvifDevice

    rig = onvif_rig(tmp_path)
    device = OnvifDevice(rig.servo, HeadMechanics(rig.head, rig.sim, 0.0), PASSWORD, "http://h")
    body = envelopes.ptz_get_nodes()

    def status(**auth: str) -> int:
        return device.handle(envelopes.build_envelope(body, **auth).encode(), 0.0)[0]

    assert status(username="admin", password=PASSWORD) == 200
    assert status(username="admin", password="wrong") == 401
    assert status(username="someone", password=PASSWORD) == 401
    assert status() == 401
    assert device.refused == 3
