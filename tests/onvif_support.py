"""Helpers of the ONVIF tests and benches: the sim ONVIF rig on a free loopback port, a virtual
clock, and ipycam (a virtual ONVIF camera nobody here wrote) serving a video on loopback."""

from __future__ import annotations

import contextlib
import importlib.util
import subprocess
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import tomlkit
from conftest import PYTHON, SUPPORT, child_env, free_tcp_port
from onveef import OnvifClient

from gazed.config import Rig, load_rig
from gazed.servo.onvif_ptz import PtzStatus, get_status, parse_status

REPO = Path(__file__).resolve().parents[1]
PASSWORD = (REPO / "configs" / "sim-onvif.password").read_text().splitlines()[0]
IPYCAM_USER, IPYCAM_PASSWORD = "admin", "s3cret"
IPYCAM_START_ZOOM = 0.5  # at zoom 0 ipycam's pan and tilt do nothing
IPYCAM_RANGE_DEG = 30.0  # `ipycam_rig`'s degrees at ipycam's generic -1 and 1
LOOP_RANGE_DEG = (11.0, 8.2)  # `loop_rig`'s pan and tilt degrees at ipycam's generic 1


def onvif_rig(tmp_path: Path, **servo: object) -> Rig:
    """configs/sim-onvif.toml on a free loopback port, with `servo` keys set (TOML values)."""
    text = (REPO / "configs" / "sim-onvif.toml").read_text()
    text = text.replace("127.0.0.1:18080", f"127.0.0.1:{free_tcp_port()}")
    text = text.replace(
        'password_file = "sim-onvif.password"',
        f'password_file = "{REPO}/configs/sim-onvif.password"',
    )
    for key, value in servo.items():
        lines = [line for line in text.splitlines() if not line.startswith(f"{key} =")]
        text = "\n".join(lines).replace("[servo]\n", f"[servo]\n{key} = {value}\n")
    path = tmp_path / "rig.toml"
    path.write_text(text)
    return load_rig(path)


@dataclass
class Clock:
    """A virtual clock: `mono_s` for the link and the emulator, `wall_ns` for the stamps."""

    mono_s: float = 1000.0
    immediate: bool = False

    @property
    def wall_ns(self) -> int:
        return round(self.mono_s * 1e9)

    def now(self) -> float:
        return self.mono_s

    def now_ns(self) -> int:
        return self.wall_ns

    def sleep(self, seconds: float) -> None:
        self.mono_s += seconds


def ipycam_installed() -> bool:
    """ipycam needs opencv-python, which clashes with the headless build gazed uses; it is
    installed next to it without its dependencies: `pip install --no-deps ipycam==1.3.0`."""
    return importlib.util.find_spec("ipycam") is not None


@contextlib.contextmanager
def running_ipycam(video: Path, folder: Path) -> Iterator[tuple[int, OnvifClient, str]]:
    """ipycam serving `video` on a free loopback port (`tests/support/ipycam_loopback.py`),
    its presets file written in `folder`, zoomed to `IPYCAM_START_ZOOM`; yields the port, an
    onveef client of its own and its first profile's token. Raises `RuntimeError` if it does
    not start."""
    port = free_tcp_port()
    process = subprocess.Popen(
        [
            PYTHON,
            str(SUPPORT / "ipycam_loopback.py"),
            str(video),
            str(port),
            IPYCAM_USER,
            IPYCAM_PASSWORD,
        ],
        cwd=folder,  # ipycam writes its presets file to the working directory
        env=child_env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        assert process.stdout is not None
        lines = iter(process.stdout.readline, "")
        if "READY" not in (line.strip() for line in lines):
            raise RuntimeError("ipycam did not start")
        threading.Thread(target=lambda: list(lines), daemon=True).start()  # drain its log
        client = OnvifClient(
            "127.0.0.1", port, IPYCAM_USER, IPYCAM_PASSWORD, retries=0, timeout_s=2.0
        )
        token = client.get_profiles()[0]["token"]
        client.ptz_absolute_move(profile_token=token, pan=0.0, tilt=0.0, zoom=IPYCAM_START_ZOOM)
        try:
            yield port, client, token
        finally:
            client.close()
    finally:
        process.terminate()
        process.wait(10)


def ipycam_status(client: OnvifClient, token: str) -> PtzStatus:
    """ipycam's own GetStatus, parsed."""
    xml = client.call(service="ptz", operation="GetStatus", body_inner=get_status(token))
    return parse_status(xml)


def ipycam_position_deg(
    client: OnvifClient,
    token: str,
    range_deg: tuple[float, float] = (IPYCAM_RANGE_DEG, IPYCAM_RANGE_DEG),
) -> tuple[float, float]:
    """ipycam's own report of its pan and tilt, in the degrees of a rig whose `pan_range_deg`
    and `tilt_range_deg` are ±`range_deg`."""
    status = ipycam_status(client, token)
    return status.pan * range_deg[0], status.tilt * range_deg[1]


def ipycam_rig(tmp_path: Path, port: int, mode: str) -> Path:
    """A servo rig on ipycam at `port` in `mode`: ±`IPYCAM_RANGE_DEG` at its generic ends."""
    password_file = tmp_path / "password"
    password_file.write_text(IPYCAM_PASSWORD + "\n")
    path = tmp_path / "ipycam.toml"
    path.write_text(
        f"""
[rig]
name = "ipycam{port}"
[bus]
listen = ["tcp/127.0.0.1:{free_tcp_port()}"]
[camera]
source = "http://{IPYCAM_USER}:{IPYCAM_PASSWORD}@127.0.0.1:{port}/stream.mjpeg"
[head]
pan_min_deg = -20
pan_max_deg = 20
tilt_min_deg = -15
tilt_max_deg = 15
pan_rate_max_deg_s = 30
tilt_rate_max_deg_s = 30
pan_accel_max_deg_s2 = 200
tilt_accel_max_deg_s2 = 200
[servo]
protocol = "onvif"
port = "onvif://127.0.0.1:{port}"
username = "{IPYCAM_USER}"
password_file = "{password_file}"
pan_range_deg = [-{IPYCAM_RANGE_DEG}, {IPYCAM_RANGE_DEG}]
tilt_range_deg = [-{IPYCAM_RANGE_DEG}, {IPYCAM_RANGE_DEG}]
pan_speed_max_deg_s = {IPYCAM_RANGE_DEG}
tilt_speed_max_deg_s = {IPYCAM_RANGE_DEG}
mode = "{mode}"
timeout_ms = 1000
command_timeout_ms = 500
odometry_rate_hz = 20
command_rate_hz = 20
"""
    )
    return path


def loop_rig(tmp_path: Path, port: int) -> Path:
    """configs/pets.toml's world (the PETS 2009 camera's calibration) seen through ipycam's
    digital PTZ: a 192x144 crop of the 480x360 footage at zoom 0.5, served at 480x360, whose
    pan and tilt of -1..1 move it 144 and 108 source pixels, about 11 and 8.2 degrees."""
    pets = tomlkit.parse((REPO / "configs" / "pets.toml").read_text())
    password_file = tmp_path / "password"
    password_file.write_text(IPYCAM_PASSWORD + "\n")
    rig = tomlkit.parse(
        f"""
[rig]
name = "ipycamloop{port}"
[bus]
listen = ["tcp/127.0.0.1:{free_tcp_port()}"]
[camera]
source = "http://{IPYCAM_USER}:{IPYCAM_PASSWORD}@127.0.0.1:{port}/stream.mjpeg"
width_px = 480
height_px = 360
rate_hz = 10.0
fx_px = 1851.6
fy_px = 1866.6
[head]
pan_min_deg = -10
pan_max_deg = 10
tilt_min_deg = -7
tilt_max_deg = 7
pan_rate_max_deg_s = 20
tilt_rate_max_deg_s = 20
pan_accel_max_deg_s2 = 100
tilt_accel_max_deg_s2 = 100
[servo]
protocol = "onvif"
port = "onvif://127.0.0.1:{port}"
username = "{IPYCAM_USER}"
password_file = "{password_file}"
pan_range_deg = [-{LOOP_RANGE_DEG[0]}, {LOOP_RANGE_DEG[0]}]
tilt_range_deg = [-{LOOP_RANGE_DEG[1]}, {LOOP_RANGE_DEG[1]}]
timeout_ms = 1000
command_timeout_ms = 500
odometry_rate_hz = 20
command_rate_hz = 20
[services.sim]
enabled = false
"""
    )
    for section in ("calibration", "vision", "estimator", "gaze"):
        rig[section] = pets[section]
    path = tmp_path / "ipycam-loop.toml"
    path.write_text(tomlkit.dumps(rig))
    return path
