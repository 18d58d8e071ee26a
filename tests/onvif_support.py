"""Helpers of the ONVIF tests: the sim ONVIF rig on a free loopback port, and a virtual clock."""

from __future__ import annotations

import socket
from dataclasses import dataclass
from pathlib import Path

from gazed.config import Rig, load_rig

REPO = Path(__file__).resolve().parents[1]
PASSWORD = (REPO / "configs" / "sim-onvif.password").read_text().splitlines()[0]


def free_tcp_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


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
