"""`gazed run configs/pets.toml`, end to end: the digital head over the PETS footage acquires a
walker (the gaze reaches pursuit), and the vision process serves the head's view as MJPEG that
OpenCV opens."""

from __future__ import annotations

import re
from pathlib import Path

import cv2
import pytest
import tomlkit
from conftest import REPO, RunningSupervisor, free_tcp_port, poll_until, unique_rig_name

from gazed.config import load_rig
from gazed.topics import GAZE_STATE

pytestmark = pytest.mark.e2e

PETS = REPO / "configs" / "pets.toml"


def private_pets_rig(tmp_path: Path) -> Path:
    """configs/pets.toml with its own name, bus port and stream port, the footage's path
    absolute (skips where the footage is absent)."""
    source = load_rig(PETS).wide_source
    assert source is not None
    if not Path(source).is_file():
        pytest.skip(f"the PETS footage {source} is absent")
    document = tomlkit.parse(PETS.read_text())
    document["rig"]["name"] = unique_rig_name("pets")
    document["bus"]["listen"] = [f"tcp/127.0.0.1:{free_tcp_port()}"]
    document["wide"]["source"] = source
    document["wide"]["stream_port"] = free_tcp_port()
    path = tmp_path / "pets.toml"
    path.write_text(tomlkit.dumps(document))
    return path


def test_pets_rig_acquires_a_walker_and_streams_its_view(tmp_path: Path) -> None:
    rig_path = private_pets_rig(tmp_path)
    supervisor = RunningSupervisor(rig_path, tmp_path)
    rig = supervisor.rig
    states = supervisor.bus.subscribe(GAZE_STATE, capacity=1000)
    seen: list[str] = []
    try:
        supervisor.wait_ready(60.0)
        poll_until(lambda: seen.extend(s.state for s in states.take()) or "pursuit" in seen, 60.0)
        stream = cv2.VideoCapture(f"http://127.0.0.1:{rig.wide.stream_port}/stream.mjpg")
        try:
            ok, frame = stream.read()
        finally:
            stream.release()
        assert ok and frame.shape[:2] == (rig.camera.height_px, rig.camera.width_px)
    finally:
        code = supervisor.stop()
    assert code == 0, "".join(supervisor.stderr)
    assert re.search(r"(saccade|search) -> pursuit", "".join(supervisor.stderr))
