"""The emulated ONVIF PTZ camera's SOAP handling, without I/O: a request envelope in, a status
code and a response envelope out, acting on the head's mechanism (`HeadMechanics`).

It speaks what the ONVIF head uses (Profile S): GetServices, GetCapabilities and
GetSystemDateAndTime on the device service; GetProfiles and GetStreamUri on media; GetNodes,
GetConfigurationOptions, GetStatus, AbsoluteMove, RelativeMove, ContinuousMove, Stop,
GetPresets and GotoPreset on PTZ. Every request must carry a WS-Security UsernameToken whose
digest, Base64(SHA1(nonce + created + password)), matches the camera's password; anything
else is answered 401 with a NotAuthorized fault. An unknown operation or profile is a SOAP
fault, a body that is not XML a 400.

Its generic spaces run -1..1 and map linearly onto the rig's `pan_range_deg`/`tilt_range_deg`
(device angles); velocity 1 is `pan_speed_max_deg_s`/`tilt_speed_max_deg_s`. ContinuousMove
runs until Stop, another move, or its Timeout. Its absolute zoom space runs 0..1, the lens's
zoom position: AbsoluteMove with a Zoom moves it, GetStatus reports it.
"""

from __future__ import annotations

import base64
import binascii
import hashlib
import hmac
import math
from datetime import UTC, datetime
from xml.etree.ElementTree import Element, ParseError

from defusedxml.ElementTree import fromstring
from onveef.envelopes import NS_DECL, XML_PROLOG

from gazed.config.servo import OnvifServo
from gazed.servo.codec import CodecError
from gazed.servo.onvif_ptz import AxisSpace, duration_s
from gazed.sim.head_mechanics import HeadMechanics

PROFILE = "gazed_profile"
PTZ_CONFIG = "gazed_ptz"
NODE = "gazed_node"
PRESETS = {"home": (0.0, 0.0)}  # token -> generic pan, tilt
WSSE = "http://docs.oasis-open.org/wss/2004/01/oasis-200401-wss-wssecurity-secext-1.0.xsd"
WSU = "http://docs.oasis-open.org/wss/2004/01/oasis-200401-wss-wssecurity-utility-1.0.xsd"
SPACE = "http://www.onvif.org/ver10/tptz/PanTiltSpaces/"
ZOOM_SPACE = "http://www.onvif.org/ver10/tptz/ZoomSpaces/"


def password_digest(nonce_b64: str, created: str, password: str) -> str:
    """WS-Security UsernameToken PasswordDigest: Base64(SHA1(nonce + created + password))."""
    nonce = base64.b64decode(nonce_b64, validate=True)
    raw = hashlib.sha1(nonce + created.encode() + password.encode(), usedforsecurity=False)
    return base64.b64encode(raw.digest()).decode()


def envelope(body: str) -> str:
    return f"{XML_PROLOG}<s:Envelope {NS_DECL}><s:Body>{body}</s:Body></s:Envelope>"


def fault(code: str, subcode: str, reason: str) -> str:
    return envelope(
        f"<s:Fault><s:Code><s:Value>s:{code}</s:Value><s:Subcode><s:Value>{subcode}</s:Value>"
        f'</s:Subcode></s:Code><s:Reason><s:Text xml:lang="en">{reason}</s:Text></s:Reason>'
        "</s:Fault>"
    )


def _local(element: Element) -> str:
    return element.tag.rsplit("}", 1)[-1]


def _child(element: Element, name: str) -> Element | None:
    return next((c for c in element.iter() if _local(c) == name), None)


def _range(name: str, uri: str, low: float = -1.0, high: float = 1.0, y: bool = True) -> str:
    y_range = f"<tt:YRange><tt:Min>{low}</tt:Min><tt:Max>{high}</tt:Max></tt:YRange>" if y else ""
    return (
        f"<tt:{name}><tt:URI>{uri}</tt:URI><tt:XRange><tt:Min>{low}</tt:Min><tt:Max>{high}"
        f"</tt:Max></tt:XRange>{y_range}</tt:{name}>"
    )


SPACES = (
    _range("AbsolutePanTiltPositionSpace", SPACE + "PositionGenericSpace")
    + _range("RelativePanTiltTranslationSpace", SPACE + "TranslationGenericSpace")
    + _range("ContinuousPanTiltVelocitySpace", SPACE + "VelocityGenericSpace")
    + _range("AbsoluteZoomPositionSpace", ZOOM_SPACE + "PositionGenericSpace", 0.0, 1.0, y=False)
)


class OnvifDevice:
    """The camera: `handle(path, xml, now_s)` -> (HTTP status, response XML). `host` is where
    its services are (http://host:port)."""

    def __init__(
        self, servo: OnvifServo, mechanics: HeadMechanics, password: str, host: str
    ) -> None:
        self.mechanics = mechanics
        self.password = password
        self.username = servo.username
        self.host = host
        pan_lo, pan_hi = (math.radians(a) for a in servo.pan_range_deg)
        tilt_lo, tilt_hi = (math.radians(a) for a in servo.tilt_range_deg)
        self.pan = AxisSpace(-1.0, 1.0, pan_lo, pan_hi)
        self.tilt = AxisSpace(-1.0, 1.0, tilt_lo, tilt_hi)
        self.velocity_rad_s = (
            math.radians(servo.pan_speed_max_deg_s),
            math.radians(servo.tilt_speed_max_deg_s),
        )
        self.requests: dict[str, int] = {}
        self.refused = 0
        self.continuous_until_s: float | None = None

    # --- the request -------------------------------------------------------------------------

    def handle(self, xml: bytes, now_s: float) -> tuple[int, str]:
        self._end_continuous(now_s)
        try:
            root = fromstring(xml)
        except (ParseError, ValueError):
            return 400, fault("Sender", "ter:WellFormed", "not XML")
        body = _child(root, "Body")
        request = next(iter(body), None) if body is not None else None
        if request is None:
            return 400, fault("Sender", "ter:WellFormed", "no request in the body")
        if not self._authorised(root):
            self.refused += 1
            return 401, fault("Sender", "ter:NotAuthorized", "Sender not authorized")
        operation = _local(request)
        self.requests[operation] = self.requests.get(operation, 0) + 1
        handler = getattr(self, f"_op_{operation}", None)
        if handler is None:
            return 400, fault("Sender", "ter:ActionNotSupported", f"no {operation}")
        token = _child(request, "ProfileToken")
        if token is not None and (token.text or "").strip() != PROFILE:
            return 400, fault("Sender", "ter:InvalidArgVal", "No such profile")
        try:
            return 200, envelope(handler(request, now_s))
        except (CodecError, KeyError, ValueError) as exc:
            return 400, fault("Sender", "ter:InvalidArgVal", f"{operation}: {exc}")

    def _authorised(self, root: Element) -> bool:
        token = root.find(f".//{{{WSSE}}}UsernameToken")
        if token is None:
            return False
        fields = {_local(c): (c.text or "").strip() for c in token}
        if fields.get("Username") != self.username:
            return False
        try:
            expected = password_digest(fields["Nonce"], fields["Created"], self.password)
        except (KeyError, binascii.Error, ValueError):
            return False
        return hmac.compare_digest(expected, fields.get("Password", ""))

    # --- device and media --------------------------------------------------------------------

    def _op_GetServices(self, _request: Element, _now_s: float) -> str:
        services = [
            ("http://www.onvif.org/ver10/device/wsdl", "device"),
            ("http://www.onvif.org/ver10/media/wsdl", "media"),
            ("http://www.onvif.org/ver20/ptz/wsdl", "ptz"),
        ]
        entries = "".join(
            f"<tds:Service><tds:Namespace>{ns}</tds:Namespace><tds:XAddr>{self.host}/onvif/"
            f"{name}_service</tds:XAddr><tds:Version><tt:Major>2</tt:Major><tt:Minor>0"
            "</tt:Minor></tds:Version></tds:Service>"
            for ns, name in services
        )
        return f"<tds:GetServicesResponse>{entries}</tds:GetServicesResponse>"

    def _op_GetSystemDateAndTime(self, _request: Element, _now_s: float) -> str:
        now = datetime.now(UTC)
        return (
            "<tds:GetSystemDateAndTimeResponse><tds:SystemDateAndTime><tt:DateTimeType>NTP"
            "</tt:DateTimeType><tt:UTCDateTime><tt:Date>"
            f"<tt:Year>{now.year}</tt:Year><tt:Month>{now.month}</tt:Month><tt:Day>{now.day}"
            f"</tt:Day></tt:Date><tt:Time><tt:Hour>{now.hour}</tt:Hour><tt:Minute>{now.minute}"
            f"</tt:Minute><tt:Second>{now.second}</tt:Second></tt:Time></tt:UTCDateTime>"
            "</tds:SystemDateAndTime></tds:GetSystemDateAndTimeResponse>"
        )

    def _op_GetProfiles(self, _request: Element, _now_s: float) -> str:
        return (
            f'<trt:GetProfilesResponse><trt:Profiles token="{PROFILE}" fixed="true">'
            f'<tt:Name>gazed</tt:Name><tt:PTZConfiguration token="{PTZ_CONFIG}">'
            f"<tt:Name>ptz</tt:Name><tt:NodeToken>{NODE}</tt:NodeToken></tt:PTZConfiguration>"
            "</trt:Profiles></trt:GetProfilesResponse>"
        )

    def _op_GetStreamUri(self, _request: Element, _now_s: float) -> str:
        return (
            "<trt:GetStreamUriResponse><trt:MediaUri><tt:Uri>"
            f"{self.host.replace('http://', 'rtsp://')}/gazed</tt:Uri></trt:MediaUri>"
            "</trt:GetStreamUriResponse>"
        )

    # --- PTZ ---------------------------------------------------------------------------------

    def _op_GetNodes(self, _request: Element, _now_s: float) -> str:
        return (
            f'<tptz:GetNodesResponse><tptz:PTZNode token="{NODE}"><tt:Name>gazed</tt:Name>'
            f"<tt:SupportedPTZSpaces>{SPACES}</tt:SupportedPTZSpaces>"
            f"<tt:MaximumNumberOfPresets>{len(PRESETS)}</tt:MaximumNumberOfPresets>"
            "<tt:HomeSupported>true</tt:HomeSupported></tptz:PTZNode></tptz:GetNodesResponse>"
        )

    def _op_GetConfigurationOptions(self, _request: Element, _now_s: float) -> str:
        return (
            "<tptz:GetConfigurationOptionsResponse><tptz:PTZConfigurationOptions><tt:Spaces>"
            f"{SPACES}</tt:Spaces><tt:PTZTimeout><tt:Min>PT0S</tt:Min><tt:Max>PT10S</tt:Max>"
            "</tt:PTZTimeout></tptz:PTZConfigurationOptions>"
            "</tptz:GetConfigurationOptionsResponse>"
        )

    def _op_GetStatus(self, _request: Element, now_s: float) -> str:
        self.mechanics.advance(now_s)
        pan_rad, tilt_rad = self.mechanics.encoder()
        moving = "IDLE" if self.mechanics.settled else "MOVING"
        utc = datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%S.%fZ")
        return (
            "<tptz:GetStatusResponse><tptz:PTZStatus><tt:Position>"
            f'<tt:PanTilt x="{self.pan.to_space(pan_rad)!r}" '
            f'y="{self.tilt.to_space(tilt_rad)!r}" space="{SPACE}PositionGenericSpace"/>'
            f'<tt:Zoom x="{self.mechanics.zoom.position_rad!r}" '
            f'space="{ZOOM_SPACE}PositionGenericSpace"/>'
            f"</tt:Position><tt:MoveStatus><tt:PanTilt>{moving}</tt:PanTilt></tt:MoveStatus>"
            f"<tt:UtcTime>{utc}</tt:UtcTime></tptz:PTZStatus></tptz:GetStatusResponse>"
        )

    def _pan_tilt(self, request: Element, name: str) -> tuple[float, float]:
        holder = _child(request, name)
        vector = _child(holder, "PanTilt") if holder is not None else None
        if vector is None:
            raise ValueError(f"no {name}/PanTilt")
        x, y = float(vector.attrib["x"]), float(vector.attrib["y"])
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError(f"not finite: {x}, {y}")
        return x, y

    def _go(self, now_s: float, pan_rad: float, tilt_rad: float) -> None:
        self.mechanics.advance(now_s)
        self.continuous_until_s = None
        self.mechanics.schedule(now_s, lambda m: (m.pan.move_to(pan_rad), m.tilt.move_to(tilt_rad)))

    def _op_AbsoluteMove(self, request: Element, now_s: float) -> str:
        position = _child(request, "Position")
        zoom = _child(position, "Zoom") if position is not None else None
        if zoom is not None:
            z = float(zoom.attrib["x"])
            if not math.isfinite(z):
                raise ValueError(f"zoom not finite: {z}")
            self.mechanics.advance(now_s)
            self.mechanics.schedule(now_s, lambda m: m.zoom.move_to(max(0.0, min(1.0, z))))
            if position is not None and _child(position, "PanTilt") is None:
                return "<tptz:AbsoluteMoveResponse/>"  # the zoom alone
        x, y = self._pan_tilt(request, "Position")
        self._go(
            now_s, self.pan.to_rad(max(-1.0, min(1.0, x))), self.tilt.to_rad(max(-1.0, min(1.0, y)))
        )
        return "<tptz:AbsoluteMoveResponse/>"

    def _op_RelativeMove(self, request: Element, now_s: float) -> str:
        dx, dy = self._pan_tilt(request, "Translation")
        self.mechanics.advance(now_s)
        pan_at, tilt_at = self.mechanics.encoder()
        x = max(-1.0, min(1.0, self.pan.to_space(pan_at) + dx))
        y = max(-1.0, min(1.0, self.tilt.to_space(tilt_at) + dy))
        self._go(now_s, self.pan.to_rad(x), self.tilt.to_rad(y))
        return "<tptz:RelativeMoveResponse/>"

    def _op_ContinuousMove(self, request: Element, now_s: float) -> str:
        vx, vy = self._pan_tilt(request, "Velocity")
        timeout = _child(request, "Timeout")
        pan_rate = max(-1.0, min(1.0, vx)) * self.velocity_rad_s[0] * _sign(self.pan)
        tilt_rate = max(-1.0, min(1.0, vy)) * self.velocity_rad_s[1] * _sign(self.tilt)
        self.mechanics.advance(now_s)
        self.mechanics.schedule(
            now_s, lambda m: (m.pan.move_at(pan_rate), m.tilt.move_at(tilt_rate))
        )
        self.continuous_until_s = (
            now_s + duration_s(timeout.text or "") if timeout is not None else None
        )
        return "<tptz:ContinuousMoveResponse/>"

    def _op_Stop(self, _request: Element, now_s: float) -> str:
        self.mechanics.advance(now_s)
        self.continuous_until_s = None
        self.mechanics.schedule(now_s, lambda m: (m.pan.hold(), m.tilt.hold()))
        return "<tptz:StopResponse/>"

    def _op_GetPresets(self, _request: Element, _now_s: float) -> str:
        presets = "".join(
            f'<tptz:Preset token="{token}"><tt:Name>{token}</tt:Name></tptz:Preset>'
            for token in PRESETS
        )
        return f"<tptz:GetPresetsResponse>{presets}</tptz:GetPresetsResponse>"

    def _op_GotoPreset(self, request: Element, now_s: float) -> str:
        token = _child(request, "PresetToken")
        x, y = PRESETS[(token.text or "").strip() if token is not None else ""]
        self._go(now_s, self.pan.to_rad(x), self.tilt.to_rad(y))
        return "<tptz:GotoPresetResponse/>"

    # --- time --------------------------------------------------------------------------------

    def _end_continuous(self, now_s: float) -> None:
        """A ContinuousMove whose Timeout has run out stops (as if Stop came then)."""
        if self.continuous_until_s is not None and now_s >= self.continuous_until_s:
            until_s, self.continuous_until_s = self.continuous_until_s, None
            self.mechanics.advance(until_s)
            acts_s = max(
                until_s - self.mechanics.latency_s, self.mechanics.t_s - self.mechanics.latency_s
            )
            self.mechanics.schedule(acts_s, lambda m: (m.pan.hold(), m.tilt.hold()))

    def advance(self, now_s: float) -> None:
        self._end_continuous(now_s)
        self.mechanics.advance(now_s)


def _sign(space: AxisSpace) -> float:
    return 1.0 if (space.high - space.low) * (space.high_rad - space.low_rad) > 0 else -1.0
