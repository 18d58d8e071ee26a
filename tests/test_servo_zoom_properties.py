"""Properties of the zoom replies (hypothesis): a zoom position reply, built here byte by byte
from the protocol's layout, is found inside garbage and in any chunking, among pan/tilt replies,
with the position the rig's zoom range gives it; whatever bytes come, a zoom reply's position
is in 0..1.

    VISCA CAM_ZoomPosInq reply   y0 50 0p 0q 0r 0s FF        (Sony EVI-D70 manual, pqrs)
    Pelco-D zoom response 0x5D   FF addr 00 5D MSB LSB ck    (ck = bytes 2..6 mod 256)
"""

from __future__ import annotations

import itertools

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gazed.servo import Reply, make_codec

SETTINGS = settings(
    max_examples=30, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
ZOOM_MAX = {"visca": 0x4000, "pelco-d": 0xFFFF}


def visca_zoom_reply(units: int) -> bytes:
    return bytes(
        (0x90, 0x50, units >> 12 & 0xF, units >> 8 & 0xF, units >> 4 & 0xF, units & 0xF, 0xFF)
    )


def visca_pan_tilt_reply() -> bytes:
    return bytes((0x90, 0x50, 0, 0, 1, 0, 0x0F, 0x0F, 0x0F, 0x0F, 0xFF))


def pelco_zoom_reply(units: int) -> bytes:
    body = bytes((0x01, 0x00, 0x5D, units >> 8, units & 0xFF))
    return bytes((0xFF, *body, sum(body) % 256))


def pelco_pan_reply() -> bytes:
    body = bytes((0x01, 0x00, 0x59, 0x03, 0xE8))  # pan 10.00°
    return bytes((0xFF, *body, sum(body) % 256))


REPLIES = {
    "visca": (visca_zoom_reply, visca_pan_tilt_reply, 0x7FFF),
    "pelco-d": (pelco_zoom_reply, pelco_pan_reply, 0xFFFF),
}


def chunked(data: bytes, cuts: list[int]) -> list[bytes]:
    points = sorted({min(c, len(data)) for c in cuts})
    return [data[a:b] for a, b in itertools.pairwise([0, *points, len(data)])]


def zooms(replies: list[Reply]) -> list[float]:
    return [r.value for r in replies if r.kind == "zoom" and r.value is not None]


@pytest.mark.parametrize("protocol", ["visca", "pelco-d"])
@SETTINGS
@given(st.data())
def test_zoom_replies_inside_garbage_and_any_chunking_are_found(
    protocol: str, data: st.DataObject
) -> None:
    zoom_reply, other_reply, units_max = REPLIES[protocol]
    units = data.draw(st.lists(st.integers(0, units_max), min_size=1, max_size=5))
    # garbage without a frame's first byte, so that it cannot swallow the frame after it
    garbage = st.binary(max_size=20).map(lambda b: b.replace(b"\xff", b"").replace(b"\x90", b""))
    stream = b"".join(
        data.draw(garbage) + zoom_reply(u) + (other_reply() if data.draw(st.booleans()) else b"")
        for u in units
    )
    cuts = data.draw(st.lists(st.integers(0, len(stream)), max_size=20))
    codec = make_codec(protocol)
    got = [r for chunk in chunked(stream, cuts) for r in codec.feed(chunk)]
    want = [min(u / ZOOM_MAX[protocol], 1.0) for u in units]
    assert zooms(got) == pytest.approx(want, abs=1e-12)
    assert all(r.kind in ("zoom", "position") for r in got)


@pytest.mark.parametrize("protocol", ["visca", "pelco-d"])
@SETTINGS
@given(data=st.binary(max_size=400), cuts=st.lists(st.integers(0, 400), max_size=10))
def test_whatever_bytes_come_a_zoom_is_in_its_range(
    protocol: str, data: bytes, cuts: list[int]
) -> None:
    codec = make_codec(protocol)
    got = [r for chunk in chunked(data, cuts) for r in codec.feed(chunk)]
    assert all(0.0 <= z <= 1.0 for z in zooms(got))
