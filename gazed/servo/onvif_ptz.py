"""ONVIF PTZ without I/O: the request bodies the ONVIF head sends, the GetStatus reply it parses,
and the map between the camera's normalised spaces and degrees.

Bodies come from onveef's builders (`onveef.envelopes`), always with both axes: onveef writes an
omitted axis as 0, which would drive it to the middle. A non-finite value is refused before it
is written (onveef would write `nan`).

GetStatus is parsed here rather than by onveef, which returns `{}` for what it cannot read:
- prefixes a device uses without declaring them (`ptz:`, `tptz:` for the PTZ namespace) are
  declared before parsing;
- a reply without a pan/tilt position is garbage (`CodecError`);
- a MoveStatus other than IDLE or MOVING (absent, or a template placeholder) is "UNKNOWN": the
  head judges moves by position, as it does for a camera whose status never leaves MOVING.

Spaces: the absolute generic space runs over the range GetNodes / GetConfigurationOptions
gives (usually -1..1, some cameras 0..1); the rig says which angles its two ends are
(`pan_range_deg`, `tilt_range_deg`), and the map is linear between them.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from xml.etree.ElementTree import Element, ParseError

from defusedxml.ElementTree import fromstring
from onveef import envelopes

from gazed.servo.codec import CodecError

NS = {
    "s": "http://www.w3.org/2003/05/soap-envelope",
    "tt": "http://www.onvif.org/ver10/schema",
    "tptz": "http://www.onvif.org/ver20/ptz/wsdl",
}
UNDECLARED_PREFIXES = {"ptz": NS["tptz"], "tptz": NS["tptz"], "tt": NS["tt"]}
MOVE_STATUSES = ("IDLE", "MOVING")


@dataclass(frozen=True)
class AxisSpace:
    """One axis of a normalised space: `low`..`high` in the camera's units are `low_rad`..
    `high_rad` in device angles."""

    low: float
    high: float
    low_rad: float
    high_rad: float

    def to_space(self, angle_rad: float) -> float:
        """A device angle in the camera's units, clamped to the range."""
        if not math.isfinite(angle_rad):
            raise CodecError(f"not a finite angle: {angle_rad}")
        w = (angle_rad - self.low_rad) / (self.high_rad - self.low_rad)
        lo, hi = sorted((self.low, self.high))
        return min(max(self.low + w * (self.high - self.low), lo), hi)

    def to_rad(self, value: float) -> float:
        w = (value - self.low) / (self.high - self.low)
        return self.low_rad + w * (self.high_rad - self.low_rad)

    @property
    def rad_per_unit(self) -> float:
        return abs(self.high_rad - self.low_rad) / abs(self.high - self.low)


@dataclass(frozen=True)
class PtzStatus:
    """GetStatus: the pan/tilt position in the camera's units and its move status, and the zoom
    position where the camera reports one."""

    pan: float
    tilt: float
    move_status: str  # IDLE, MOVING or UNKNOWN
    zoom: float | None = None


def _finite(*values: float) -> None:
    if not all(math.isfinite(v) for v in values):
        raise CodecError(f"not finite: {values}")


def absolute_move(profile: str, pan: float, tilt: float) -> str:
    _finite(pan, tilt)
    return envelopes.ptz_absolute_move(profile_token=profile, pan=pan, tilt=tilt, zoom=None)


def absolute_zoom(profile: str, zoom: float) -> str:
    """AbsoluteMove of the zoom alone (a Position with no PanTilt leaves pan and tilt be)."""
    _finite(zoom)
    return envelopes.ptz_absolute_move(profile_token=profile, pan=None, tilt=None, zoom=zoom)


def relative_move(profile: str, pan: float, tilt: float) -> str:
    _finite(pan, tilt)
    return envelopes.ptz_relative_move(profile_token=profile, pan=pan, tilt=tilt, zoom=None)


def continuous_move(profile: str, pan: float, tilt: float, timeout_s: float) -> str:
    """Both velocities (-1..1), with the camera's own stop after `timeout_s`."""
    _finite(pan, tilt, timeout_s)
    return envelopes.ptz_continuous_move(
        profile_token=profile, pan=pan, tilt=tilt, zoom=None, timeout=f"PT{timeout_s:.3f}S"
    )


def stop(profile: str) -> str:
    return envelopes.ptz_stop(profile_token=profile, pan_tilt=True, zoom=False)


def goto_preset(profile: str, preset: str) -> str:
    return envelopes.ptz_goto_preset(profile_token=profile, preset_token=preset)


def get_status(profile: str) -> str:
    return envelopes.ptz_get_status(profile_token=profile)


def declare_prefixes(xml: str) -> str:
    """Declare on the envelope the ONVIF prefixes the reply uses without declaring them."""
    start = xml.find("<s:Envelope")
    if start < 0:
        return xml
    head_end = xml.find(">", start)
    head = xml[start:head_end]
    missing = [
        f'xmlns:{prefix}="{uri}"'
        for prefix, uri in UNDECLARED_PREFIXES.items()
        if f"<{prefix}:" in xml and f"xmlns:{prefix}=" not in head
    ]
    if not missing:
        return xml
    return f"{xml[:head_end]} {' '.join(missing)}{xml[head_end:]}"


def _parse(xml: str) -> Element:
    try:
        return fromstring(declare_prefixes(xml).encode())
    except (ParseError, ValueError) as exc:
        raise CodecError(f"not XML: {exc}") from exc


def parse_status(xml: str) -> PtzStatus:
    """The PTZStatus of a GetStatus reply (raises `CodecError` for anything else)."""
    root = _parse(xml)
    pan_tilt = root.find(".//tptz:PTZStatus/tt:Position/tt:PanTilt", NS)
    if pan_tilt is None:
        raise CodecError("GetStatus reply without a pan/tilt position")
    try:
        pan, tilt = float(pan_tilt.attrib["x"]), float(pan_tilt.attrib["y"])
    except (KeyError, ValueError) as exc:
        raise CodecError(f"GetStatus pan/tilt unreadable: {pan_tilt.attrib}") from exc
    if not (math.isfinite(pan) and math.isfinite(tilt)):
        raise CodecError(f"GetStatus pan/tilt not finite: {pan}, {tilt}")
    status = root.findtext(".//tptz:PTZStatus/tt:MoveStatus/tt:PanTilt", "", NS).strip()
    zoom_element = root.find(".//tptz:PTZStatus/tt:Position/tt:Zoom", NS)
    zoom = None
    if zoom_element is not None:
        try:
            zoom = float(zoom_element.attrib["x"])
        except (KeyError, ValueError) as exc:
            raise CodecError(f"GetStatus zoom unreadable: {zoom_element.attrib}") from exc
        if not math.isfinite(zoom):
            raise CodecError(f"GetStatus zoom not finite: {zoom}")
    return PtzStatus(pan, tilt, status if status in MOVE_STATUSES else "UNKNOWN", zoom)


def duration_s(text: str) -> float:
    """An xs:duration of seconds and minutes (PT0.5S, PT1M) in seconds."""
    match = re.fullmatch(r"PT(?:(\d+(?:\.\d*)?)M)?(?:(\d+(?:\.\d*)?)S)?", text.strip())
    if match is None or not any(match.groups()):
        raise CodecError(f"not a duration: {text!r}")
    minutes, seconds = (float(g) if g else 0.0 for g in match.groups())
    return 60.0 * minutes + seconds
