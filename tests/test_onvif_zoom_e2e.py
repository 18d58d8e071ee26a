"""ONVIF zoom end to end: the real `servo` process drives the zoom of ipycam, a virtual ONVIF
camera nobody here wrote, over ONVIF on loopback. The demand's zoom reaches ipycam no faster
than `[head] zoom_rate_max_s` (ipycam itself zooms at once), the servo's odometry carries the
zoom ipycam reports, and on SIGTERM the servo parks it at its widest view.

Needs ipycam (CI: `pip install --no-deps ipycam==1.3.0`) and the shared footage.
"""

from __future__ import annotations

import itertools
import time
from pathlib import Path

import pytest
from conftest import poll_until, start_service
from onveef import OnvifClient
from onvif_support import IPYCAM_START_ZOOM, ipycam_rig, ipycam_status
from servo_link_support import demand
from test_onvif_e2e import ipycam  # noqa: F401  (the fixture)

from gazed.bus import Bus
from gazed.config import load_rig
from gazed.topics import GAZE_DEMAND, SERVO_ODOMETRY, SERVO_STATUS

pytestmark = pytest.mark.e2e

ZOOM_RATE_MAX_S = 0.5


def zoom_rig(tmp_path: Path, port: int) -> Path:
    """The ipycam rig in position mode with a zoom lens that zooms across its range in 2 s."""
    path = ipycam_rig(tmp_path, port, "position")
    text = path.read_text()
    text = text.replace("[camera]\n", "[camera]\nzoom_focal_px = [[0.0, 400.0], [1.0, 1600.0]]\n")
    text = text.replace("[head]\n", f"[head]\nzoom_rate_max_s = {ZOOM_RATE_MAX_S}\n")
    path.write_text(text)
    return path


def ipycam_zoom(client: OnvifClient, token: str) -> float | None:
    return ipycam_status(client, token).zoom


def test_the_servo_zooms_ipycam_at_the_rigs_rate_and_reports_its_zoom(
    ipycam,  # noqa: F811
    tmp_path: Path,
) -> None:
    port, client, token = ipycam
    rig_path = zoom_rig(tmp_path, port)
    rig = load_rig(rig_path)
    assert rig.camera.zoom_focal_px
    with Bus(rig, "test", router=True) as bus:
        demands = bus.publisher(GAZE_DEMAND)
        odometry = bus.subscribe(SERVO_ODOMETRY)
        statuses = bus.subscribe(SERVO_STATUS)
        servo = start_service("servo", rig_path)
        readings: list = []

        def zoomed_to(zoom: float | None) -> bool:
            demands.put(demand(5.0, 0.0).model_copy(update={"zoom": zoom}))
            readings.extend(odometry.take())
            time.sleep(0.05)
            return len(readings) >= 2 and all(
                r.zoom is not None and abs(r.zoom - (zoom or IPYCAM_START_ZOOM)) < 1e-3
                for r in readings[-2:]
            )

        try:
            poll_until(lambda: zoomed_to(None), 20.0, interval_s=0.0)  # connected, zoom left
            readings.clear()
            for target in (0.8, 0.3):
                poll_until(lambda t=target: zoomed_to(t), 20.0, interval_s=0.0)
                assert ipycam_zoom(client, token) == pytest.approx(target, abs=1e-3)
        finally:
            servo.terminate()
            out, _ = servo.communicate(timeout=20)
        assert servo.returncode == 0, out
        status = [s for s in statuses.take() if s.link == "connected"][-1]
        assert status.errors == 0, status.last_error
    zooms = [(r.t_capture_ns * 1e-9, r.zoom) for r in readings if r.zoom is not None]
    write_s = 0.1  # the zoom drive writes at most this often, each time by up to a period's slew
    assert all(  # ipycam would jump: the servo slews it
        b - a <= ZOOM_RATE_MAX_S * (tb - ta + write_s) + 1e-3
        for (ta, a), (tb, b) in itertools.combinations(zooms, 2)
    )
    assert zooms[0][1] == pytest.approx(IPYCAM_START_ZOOM, abs=0.05)
    assert max(z for _, z in zooms) == pytest.approx(0.8, abs=1e-3)
    assert ipycam_zoom(client, token) == pytest.approx(0.0, abs=1e-6)  # parked wide
